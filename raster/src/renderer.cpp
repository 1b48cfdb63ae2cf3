// The OSMesa renderer: the one file of pliant that talks to OpenGL. A legacy (compatibility
// profile) pipeline is enough and simplest: client vertex arrays, fixed-function lighting
// (two lights, separate specular), the field's colour map as a 1D texture so colours are
// interpolated in value rather than in RGB, 4x multisampling through a renderbuffer FBO
// resolved into OSMesa's buffer. OSMesa's rows come out bottom-up and are flipped on readback.
// Text, colour bar, probes and legend are drawn afterwards on the CPU (overlay.cpp).
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <stdexcept>

#include "overlay.hpp"
#include "pliant/error.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/render.hpp"
#include "view_math.hpp"

namespace pliant::raster {

using detail::V3;

namespace {

constexpr double kCreaseCos = 0.64;  // normals split across edges sharper than ~50 degrees

// Vertex arrays of one body's surface: smooth normals (area-weighted over the triangles around
// each node), duplicated where the surface has a crease so that box edges stay sharp.
struct MeshArrays {
  std::vector<float> position, normal, texcoord;
  std::vector<GLuint> index;
};

void build_arrays(const SurfaceBody& body, double lo, double hi, MeshArrays& out) {
  const auto& tris = body.topology->triangles;
  const std::size_t nv = body.points.size() / 3, nt = tris.size();
  const float* P = body.points.data();
  // Triangle normals: area-weighted (raw cross product) and unit.
  std::vector<float> area_n(3 * nt), unit_n(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const float* a = P + 3 * tris[t][0];
    const float* b = P + 3 * tris[t][1];
    const float* c = P + 3 * tris[t][2];
    const float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const float n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; ++k) {
      area_n[3 * t + k] = n[k];
      unit_n[3 * t + k] = len > 0 ? n[k] / len : 0.f;
    }
  }
  // Node -> (triangle, corner) incidence.
  std::vector<std::uint32_t> offset(nv + 1, 0), inc(3 * nt);
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k) ++offset[std::size_t(t[k]) + 1];
  for (std::size_t i = 0; i < nv; ++i) offset[i + 1] += offset[i];
  {
    std::vector<std::uint32_t> cur(offset.begin(), offset.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) inc[cur[std::size_t(tris[t][k])]++] = std::uint32_t(3 * t + k);
  }
  out.position.clear();
  out.normal.clear();
  out.texcoord.clear();
  out.position.reserve(3 * nv + nv / 8);
  out.normal.reserve(3 * nv + nv / 8);
  out.index.assign(3 * nt, 0);
  const bool field = !body.values.empty();
  if (field) out.texcoord.reserve(nv + nv / 8);
  const double scale = hi > lo ? 1.0 / (hi - lo) : 0.0;
  // Per node: group its triangles into smoothing groups (a triangle joins the first group whose
  // seed normal is within the crease angle), one output vertex per group.
  struct Group {
    std::uint32_t seed;
    float n[3];
  };
  std::vector<Group> groups;
  for (std::size_t v = 0; v < nv; ++v) {
    groups.clear();
    for (std::uint32_t k = offset[v]; k < offset[v + 1]; ++k) {
      const std::uint32_t t = inc[k] / 3;
      const float* un = &unit_n[3 * t];
      std::size_t g = 0;
      for (; g < groups.size(); ++g) {
        const float* s = &unit_n[3 * groups[g].seed];
        if (un[0] * s[0] + un[1] * s[1] + un[2] * s[2] >= kCreaseCos) break;
      }
      if (g == groups.size()) groups.push_back({t, {0, 0, 0}});
      for (int c = 0; c < 3; ++c) groups[g].n[c] += area_n[3 * t + c];
      out.index[inc[k]] = GLuint(out.position.size() / 3 + g);
    }
    float value = 0;
    if (field) {
      const double x = body.values[v];
      value = std::isfinite(x) ? float(std::clamp((x - lo) * scale, 0.0, 1.0)) : 0.f;
    }
    for (const Group& g : groups) {
      const float len = std::sqrt(g.n[0] * g.n[0] + g.n[1] * g.n[1] + g.n[2] * g.n[2]);
      for (int c = 0; c < 3; ++c) {
        out.position.push_back(P[3 * v + c]);
        out.normal.push_back(len > 0 ? g.n[c] / len : (c == 2 ? 1.f : 0.f));
      }
      if (field) out.texcoord.push_back(value);
    }
  }
}

// A pleasant plain colour per body when no field is shown.
const float* body_colour(std::size_t i) {
  static constexpr float kColours[][3] = {{0.86f, 0.56f, 0.50f}, {0.55f, 0.68f, 0.84f}, {0.62f, 0.80f, 0.58f},
                                          {0.88f, 0.78f, 0.48f}, {0.74f, 0.62f, 0.84f}};
  return kColours[i % 5];
}

}  // namespace

struct Renderer::Impl {
  OSMesaContext ctx = nullptr;
  std::vector<std::uint8_t> buffer;
  int width = 0, height = 0;
  GLuint fbo = 0, colour_rb = 0, depth_rb = 0, colormap = 0;
  int fbo_samples = 0;
  MeshArrays arrays;

  Impl() {
    // RGBA with a 24-bit depth buffer; the compatibility profile (GL 4.5 on llvmpipe).
    ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
    if (!ctx) throw std::runtime_error("raster: OSMesa could not create a GL context (libosmesa6 installed?)");
  }
  ~Impl() {
    if (ctx) {
      if (width > 0) {
        release_fbo();
        if (colormap) glDeleteTextures(1, &colormap);
      }
      OSMesaDestroyContext(ctx);
    }
  }

  void release_fbo() {
    if (fbo) glDeleteFramebuffers(1, &fbo);
    if (colour_rb) glDeleteRenderbuffers(1, &colour_rb);
    if (depth_rb) glDeleteRenderbuffers(1, &depth_rb);
    fbo = colour_rb = depth_rb = 0;
    fbo_samples = 0;
  }

  void prepare(int w, int h, int samples) {
    if (w != width || h != height) {
      if (width > 0) release_fbo();
      buffer.assign(std::size_t(w) * h * 4, 0);
      if (!OSMesaMakeCurrent(ctx, buffer.data(), GL_UNSIGNED_BYTE, w, h))
        throw std::runtime_error(fmt::format("raster: OSMesa could not use a {}x{} buffer", w, h));
      width = w;
      height = h;
    } else if (OSMesaGetCurrentContext() != ctx) {
      OSMesaMakeCurrent(ctx, buffer.data(), GL_UNSIGNED_BYTE, w, h);
    }
    if (!colormap) {
      std::uint8_t texels[256 * 4];
      for (int i = 0; i < 256; ++i) {
        const Rgba c = viridis(i / 255.0);
        texels[4 * i] = c.r;
        texels[4 * i + 1] = c.g;
        texels[4 * i + 2] = c.b;
        texels[4 * i + 3] = 255;
      }
      glGenTextures(1, &colormap);
      glBindTexture(GL_TEXTURE_1D, colormap);
      glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexImage1D(GL_TEXTURE_1D, 0, GL_RGBA8, 256, 0, GL_RGBA, GL_UNSIGNED_BYTE, texels);
    }
    GLint max_samples = 0;
    glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
    samples = std::min(samples, int(max_samples));
    if (samples > 1 && samples != fbo_samples) {
      release_fbo();
      glGenFramebuffers(1, &fbo);
      glBindFramebuffer(GL_FRAMEBUFFER, fbo);
      glGenRenderbuffers(1, &colour_rb);
      glBindRenderbuffer(GL_RENDERBUFFER, colour_rb);
      glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_rb);
      glGenRenderbuffers(1, &depth_rb);
      glBindRenderbuffer(GL_RENDERBUFFER, depth_rb);
      glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH24_STENCIL8, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
      if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) release_fbo();
      else fbo_samples = samples;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, samples > 1 ? fbo : 0);
  }

  void draw_background() {
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_LIGHTING);
    glDisable(GL_TEXTURE_1D);
    glMatrixMode(GL_PROJECTION);
    glLoadIdentity();
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    glBegin(GL_QUADS);
    glColor3f(0.80f, 0.82f, 0.86f);
    glVertex2f(-1, -1);
    glVertex2f(1, -1);
    glColor3f(0.96f, 0.965f, 0.975f);
    glVertex2f(1, 1);
    glVertex2f(-1, 1);
    glEnd();
  }

  // A grid of lines on a plane over a floor: faint (the ground under the bodies), or solid and
  // tinted (an obstacle the bodies rest on, drawn with depth so that it hides what is below it).
  void draw_grid(const detail::Grid& g, int text_scale, bool obstacle = false) {
    glDisable(GL_LIGHTING);
    glDisable(GL_TEXTURE_1D);
    glEnable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(obstacle ? GL_TRUE : GL_FALSE);
    if (obstacle) {  // lines a little in front of their floor
      glEnable(GL_POLYGON_OFFSET_FILL);
      glPolygonOffset(1.f, 1.f);
    }
    glBegin(GL_QUADS);
    if (obstacle) glColor4f(0.80f, 0.74f, 0.64f, 1.f);  // a table top
    else glColor4f(1.f, 1.f, 1.f, 0.35f);               // a faint floor
    for (auto [a, b] : {std::pair{g.a0, g.b0}, {g.a1, g.b0}, {g.a1, g.b1}, {g.a0, g.b1}}) {
      const V3 p = g.at(a, b);
      glVertex3d(p.x, p.y, p.z);
    }
    glEnd();
    glDisable(GL_POLYGON_OFFSET_FILL);
    glLineWidth(float(std::max(1, text_scale / 2)));
    glBegin(GL_LINES);
    const int na = int(std::lround((g.a1 - g.a0) / g.spacing)), nb = int(std::lround((g.b1 - g.b0) / g.spacing));
    for (int i = 0; i <= na; ++i) {
      const double a = g.a0 + i * g.spacing;
      const bool major = std::lround(a / g.spacing) % 5 == 0;
      glColor4f(0.42f, 0.45f, 0.52f, major ? 0.7f : 0.4f);
      const V3 p = g.at(a, g.b0), q = g.at(a, g.b1);
      glVertex3d(p.x, p.y, p.z);
      glVertex3d(q.x, q.y, q.z);
    }
    for (int j = 0; j <= nb; ++j) {
      const double b = g.b0 + j * g.spacing;
      const bool major = std::lround(b / g.spacing) % 5 == 0;
      glColor4f(0.42f, 0.45f, 0.52f, major ? 0.7f : 0.4f);
      const V3 p = g.at(g.a0, b), q = g.at(g.a1, b);
      glVertex3d(p.x, p.y, p.z);
      glVertex3d(q.x, q.y, q.z);
    }
    glEnd();
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
  }

  void setup_lights() {
    glMatrixMode(GL_MODELVIEW);
    glPushMatrix();
    glLoadIdentity();  // lights fixed to the eye: key from the upper left, fill from the right
    const GLfloat key_pos[] = {-0.45f, 0.65f, 0.62f, 0.f}, key_diff[] = {0.72f, 0.72f, 0.70f, 1.f},
                  key_spec[] = {0.22f, 0.22f, 0.22f, 1.f};
    const GLfloat fill_pos[] = {0.7f, -0.2f, 0.5f, 0.f}, fill_diff[] = {0.26f, 0.27f, 0.30f, 1.f},
                  none[] = {0.f, 0.f, 0.f, 1.f};
    const GLfloat ambient[] = {0.30f, 0.30f, 0.32f, 1.f};
    glLightfv(GL_LIGHT0, GL_POSITION, key_pos);
    glLightfv(GL_LIGHT0, GL_DIFFUSE, key_diff);
    glLightfv(GL_LIGHT0, GL_SPECULAR, key_spec);
    glLightfv(GL_LIGHT0, GL_AMBIENT, none);
    glLightfv(GL_LIGHT1, GL_POSITION, fill_pos);
    glLightfv(GL_LIGHT1, GL_DIFFUSE, fill_diff);
    glLightfv(GL_LIGHT1, GL_SPECULAR, none);
    glLightfv(GL_LIGHT1, GL_AMBIENT, none);
    glLightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
    glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE);  // inverted elements stay lit
    glLightModeli(GL_LIGHT_MODEL_COLOR_CONTROL, GL_SEPARATE_SPECULAR_COLOR);
    glEnable(GL_LIGHT0);
    glEnable(GL_LIGHT1);
    glPopMatrix();
  }

  void draw_body(const SurfaceBody& body, std::size_t index, const std::array<double, 2>& range, bool lit) {
    if (body.topology->triangles.empty()) return;
    build_arrays(body, range[0], range[1], arrays);
    glEnableClientState(GL_VERTEX_ARRAY);
    glVertexPointer(3, GL_FLOAT, 0, arrays.position.data());
    if (lit) {
      glEnable(GL_LIGHTING);
      glEnableClientState(GL_NORMAL_ARRAY);
      glNormalPointer(GL_FLOAT, 0, arrays.normal.data());
      const bool field = !arrays.texcoord.empty();
      const float* base = field ? nullptr : body_colour(index);
      const GLfloat white[] = {1.f, 1.f, 1.f, 1.f};
      const GLfloat col[] = {base ? base[0] : 1.f, base ? base[1] : 1.f, base ? base[2] : 1.f, 1.f};
      const GLfloat spec[] = {1.f, 1.f, 1.f, 1.f};
      glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT, field ? white : col);
      glMaterialfv(GL_FRONT_AND_BACK, GL_DIFFUSE, field ? white : col);
      glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, spec);
      glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 40.f);
      if (field) {
        glEnable(GL_TEXTURE_1D);
        glBindTexture(GL_TEXTURE_1D, colormap);
        glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_MODULATE);
        glEnableClientState(GL_TEXTURE_COORD_ARRAY);
        glTexCoordPointer(1, GL_FLOAT, 0, arrays.texcoord.data());
      }
    }
    glDrawElements(GL_TRIANGLES, GLsizei(arrays.index.size()), GL_UNSIGNED_INT, arrays.index.data());
    glDisableClientState(GL_TEXTURE_COORD_ARRAY);
    glDisableClientState(GL_NORMAL_ARRAY);
    glDisableClientState(GL_VERTEX_ARRAY);
    glDisable(GL_TEXTURE_1D);
    glDisable(GL_LIGHTING);
  }

  // Tools as lit grey capsules (a sphere is one of zero length): a cylinder between the axis
  // ends and a hemisphere at each, from a 24 x 12 grid of directions.
  void draw_tool(const ToolMark& t) {
    glEnable(GL_LIGHTING);
    const GLfloat grey[] = {0.55f, 0.57f, 0.6f, 1.f}, spec[] = {0.8f, 0.8f, 0.8f, 1.f};
    glMaterialfv(GL_FRONT_AND_BACK, GL_AMBIENT, grey);
    glMaterialfv(GL_FRONT_AND_BACK, GL_DIFFUSE, grey);
    glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, spec);
    glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 60.f);
    // An orthonormal frame (u, v, w) with w along the axis (z for a sphere).
    Vec3d w{t.b[0] - t.a[0], t.b[1] - t.a[1], t.b[2] - t.a[2]};
    const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    w = len > 0 ? Vec3d{w[0] / len, w[1] / len, w[2] / len} : Vec3d{0, 0, 1};
    const Vec3d h = std::abs(w[0]) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
    Vec3d u{h[1] * w[2] - h[2] * w[1], h[2] * w[0] - h[0] * w[2], h[0] * w[1] - h[1] * w[0]};
    const double un = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    u = {u[0] / un, u[1] / un, u[2] / un};
    const Vec3d v{w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2], w[0] * u[1] - w[1] * u[0]};
    constexpr int kAround = 24, kUp = 12;  // kUp rows from the -w pole to the +w pole
    auto vertex = [&](int i, int j, const Vec3d& centre) {
      const double phi = 2 * M_PI * i / kAround, theta = M_PI * j / kUp - M_PI / 2;  // theta: latitude
      const double c = std::cos(theta), s = std::sin(theta);
      Vec3d n;
      for (int k = 0; k < 3; ++k) n[std::size_t(k)] = c * (std::cos(phi) * u[std::size_t(k)] + std::sin(phi) * v[std::size_t(k)]) + s * w[std::size_t(k)];
      glNormal3d(n[0], n[1], n[2]);
      glVertex3d(centre[0] + t.radius * n[0], centre[1] + t.radius * n[1], centre[2] + t.radius * n[2]);
    };
    // Rows 0 .. kUp/2 around a (the lower cap), the cylinder from a's equator to b's, rows kUp/2 .. kUp around b.
    for (int j = 0; j <= kUp; ++j) {
      if (j == kUp / 2 && len == 0) continue;
      const bool cylinder = j == kUp / 2;
      const int j0 = cylinder ? j : (j < kUp / 2 ? j : j - 1), j1 = cylinder ? j : j0 + 1;
      const Vec3d& c0 = (j <= kUp / 2) ? t.a : t.b;
      const Vec3d& c1 = (j < kUp / 2) ? t.a : t.b;
      glBegin(GL_QUAD_STRIP);
      for (int i = 0; i <= kAround; ++i) {
        vertex(i % kAround, j1, c1);  // counter-clockwise seen from outside (front faces out)
        vertex(i % kAround, j0, c0);
      }
      glEnd();
    }
    glDisable(GL_LIGHTING);
  }

  // Fixed and driven nodes as round points in a bright colour over a dark outline (a larger
  // point drawn first), so that they show on every colour of the map, dark purple to yellow,
  // and on the plain body colours. The colours are overlay.cpp's (the legend's).
  void draw_marks(const SurfaceBody& body, int text_scale) {
    const auto& topo = *body.topology;
    const float size = float(detail::mark_diameter(text_scale)), outline = float(detail::mark_outline(text_scale));
    glEnable(GL_POINT_SMOOTH);
    auto points = [&](const std::vector<std::int32_t>& nodes, Rgba c, float px) {
      if (nodes.empty()) return;
      glPointSize(px);
      glColor3ub(c.r, c.g, c.b);
      glBegin(GL_POINTS);
      for (std::int32_t n : nodes) glVertex3fv(&body.points[3 * std::size_t(n)]);
      glEnd();
    };
    for (const auto* nodes : {&topo.fixed, &topo.driven}) points(*nodes, detail::kMarkOutline, size + 2 * outline);
    points(topo.fixed, detail::kFixedColour, size);
    points(topo.driven, detail::kDrivenColour, size);
    glDisable(GL_POINT_SMOOTH);
  }

  // Reads the default framebuffer (OSMesa's buffer) into an image, flipping rows.
  Image read_back() {
    glFinish();
    Image img(width, height);
    std::memcpy(img.data(), buffer.data(), buffer.size());
    img.flip_vertical();
    // The picture is opaque; blending (the floor) leaves partial alpha in the buffer.
    for (std::size_t i = 3; i < buffer.size(); i += 4) img.data()[i] = 255;
    return img;
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;

Image Renderer::render(const Frame& frame, const RenderOptions& options) { return render(frame, options, nullptr); }

Image Renderer::render(const Frame& frame, const RenderOptions& o, std::vector<std::uint8_t>* body_mask) {
  if (o.width < 16 || o.height < 16 || o.width > 16384 || o.height > 16384)
    throw InputError(fmt::format("picture size {}x{}: width and height must be in [16, 16384] pixels", o.width, o.height));
  if (o.preset == CameraPreset::scene && o.camera) validate_camera(*o.camera, "camera");
  Impl& m = *impl_;
  const detail::Setup setup = detail::make_setup(frame, o);
  const detail::Layout& layout = setup.layout;
  const detail::Camera& cam = setup.camera;
  const std::array<double, 2> range = o.range ? *o.range : default_range(frame);

  m.prepare(o.width, o.height, std::max(o.samples, 1));
  glViewport(0, 0, o.width, o.height);
  glClearColor(0.9f, 0.9f, 0.92f, 1.f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  glShadeModel(GL_SMOOTH);
  glDisable(GL_CULL_FACE);
  m.draw_background();

  glMatrixMode(GL_PROJECTION);
  glLoadMatrixd(cam.projection.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(cam.modelview.data());
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  if (o.grid)
    for (const detail::Grid& grid : setup.grids) m.draw_grid(grid, layout.text_scale, setup.obstacles);

  m.setup_lights();
  glEnable(GL_POLYGON_OFFSET_FILL);  // surfaces a little behind their marks
  glPolygonOffset(1.f, 2.f);
  for (std::size_t b = 0; b < frame.bodies.size(); ++b) m.draw_body(frame.bodies[b], b, range, true);
  glDisable(GL_POLYGON_OFFSET_FILL);
  for (const ToolMark& t : frame.tools) m.draw_tool(t);
  if (o.marks)
    for (const auto& body : frame.bodies) m.draw_marks(body, layout.text_scale);

  if (m.fbo_samples > 1) {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    glBlitFramebuffer(0, 0, o.width, o.height, 0, 0, o.width, o.height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  Image image = m.read_back();

  if (body_mask) {  // a flat, single-sampled pass of the bodies alone
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glClearColor(0.f, 0.f, 0.f, 1.f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glMatrixMode(GL_PROJECTION);
    glLoadMatrixd(cam.projection.data());
    glMatrixMode(GL_MODELVIEW);
    glLoadMatrixd(cam.modelview.data());
    glEnable(GL_DEPTH_TEST);
    glColor3f(1.f, 1.f, 1.f);
    for (std::size_t b = 0; b < frame.bodies.size(); ++b) m.draw_body(frame.bodies[b], b, range, false);
    const Image mask = m.read_back();
    body_mask->assign(std::size_t(o.width) * o.height, 0);
    for (std::size_t i = 0; i < body_mask->size(); ++i) (*body_mask)[i] = mask.bytes()[4 * i] > 127 ? 1 : 0;
  }

  detail::draw_overlays(image, frame, o, layout, cam, range);
  return image;
}

}  // namespace pliant::raster
