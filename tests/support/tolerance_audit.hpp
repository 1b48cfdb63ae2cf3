// Tolerance audit (scripts/tolerance-audit.sh): force-included into every test source of a build
// configured with -DPLIANT_TOLERANCE_AUDIT=ON. EXPECT_NEAR, EXPECT_LT and EXPECT_LE still check
// what they checked, and also record, per source line, the largest measured / allowed seen
// (|a - b| / tol for NEAR, a / b for LT and LE when both are positive). At exit the records are
// appended to $PLIANT_AUDIT_OUT. A check whose largest ratio stays below 0.1 allows more than 10x
// what it measured (docs: the preamble's "within 10x of measured").
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace pliant_audit {

struct Entry {
  std::string expr;
  double worst = 0;
  long count = 0;
};

class Table {
 public:
  void record(const char* file, int line, const char* expr, double ratio) {
    std::lock_guard<std::mutex> lock(mutex_);
    Entry& e = entries_[{file, line}];
    if (e.count == 0) e.expr = expr;
    ++e.count;
    if (ratio > e.worst || std::isnan(ratio)) e.worst = ratio;
  }
  ~Table() {
    const char* out = std::getenv("PLIANT_AUDIT_OUT");
    if (!out) return;
    if (std::FILE* f = std::fopen(out, "a")) {
      for (const auto& [where, e] : entries_)
        std::fprintf(f, "%s:%d\t%.3g\t%ld\t%s\n", where.first.c_str(), where.second, e.worst, e.count, e.expr.c_str());
      std::fclose(f);
    }
  }

 private:
  std::mutex mutex_;
  std::map<std::pair<std::string, int>, Entry> entries_;
};
inline Table& table() {
  static Table t;
  return t;
}

// Swallows the messages streamed after a check (the check itself reported through ADD_FAILURE_AT).
struct Sink {
  template <class T>
  Sink& operator<<(const T&) {
    return *this;
  }
};

template <class A, class B, class C>
Sink near(const char* file, int line, const char* expr, const A& a, const B& b, const C& tol) {
  const double d = std::fabs(double(a) - double(b)), t = double(tol);
  table().record(file, line, expr, t > 0 ? d / t : (d == 0 ? 0.0 : INFINITY));
  if (!(d <= t)) ADD_FAILURE_AT(file, line) << expr << ": |" << double(a) << " - " << double(b) << "| = " << d << " > " << t;
  return {};
}
template <class A, class B>
Sink less(const char* file, int line, const char* expr, const A& a, const B& b, bool or_equal) {
  const double x = double(a), y = double(b);
  if (x >= 0 && y > 0) table().record(file, line, expr, x / y);
  if (!(or_equal ? a <= b : a < b)) ADD_FAILURE_AT(file, line) << expr << ": " << x << (or_equal ? " > " : " >= ") << y;
  return {};
}

}  // namespace pliant_audit

#undef EXPECT_NEAR
#define EXPECT_NEAR(a, b, tol) ::pliant_audit::near(__FILE__, __LINE__, #a, (a), (b), (tol))
#undef EXPECT_LT
#define EXPECT_LT(a, b) ::pliant_audit::less(__FILE__, __LINE__, #a, (a), (b), false)
#undef EXPECT_LE
#define EXPECT_LE(a, b) ::pliant_audit::less(__FILE__, __LINE__, #a, (a), (b), true)
