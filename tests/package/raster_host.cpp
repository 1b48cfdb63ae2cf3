// A host that draws a picture through an installed pliant::raster: a soft block's rest state,
// written to the PNG named by its argument. A smoke test that the package links and runs (raster's
// own tests check the pixels): exits non-zero when fewer than 1000 pixels differ from the picture
// of an empty world (measured: 459 371 of 1280 x 720 differ; the view is fitted to the block).
#include <cstdio>
#include <exception>

#include "pliant/raster/render.hpp"
#include "pliant/world.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: raster_host OUT.png\n");
    return 2;
  }
  try {
    using namespace pliant;
    World world(WorldDef{}), empty(WorldDef{});
    BodyDef body;
    body.name = "block";
    world.add_body(body, make_box_mesh({0, 0, 0}, {0.1, 0.1, 0.05}, {4, 4, 2}));
    raster::Renderer renderer;
    raster::RenderOptions options;
    const raster::Image image = renderer.render(raster::capture(world, raster::Field::none), options);
    const raster::Image blank = renderer.render(raster::capture(empty, raster::Field::none), options);
    long differ = 0;
    for (int y = 0; y < image.height() && y < blank.height(); ++y)
      for (int x = 0; x < image.width() && x < blank.width(); ++x) differ += !(image.get(x, y) == blank.get(x, y));
    raster::write_png(image, argv[1]);
    std::printf("%dx%d picture, %ld pixels differ from an empty world's\n", image.width(), image.height(), differ);
    return differ > 1000 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "raster_host: %s\n", e.what());
    return 2;
  }
}
