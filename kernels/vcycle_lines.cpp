// The smoother's lines of a V-cycle level (see vcycle_preconditioner.hpp): their nodes in
// grid order, each line's band width and couplings, the lines' colours, and each line's band
// Cholesky factor. factor() in vcycle_setup.cpp runs them; the cycle's line solves are in
// vcycle_preconditioner.cpp.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "kernels/vcycle_preconditioner.hpp"

namespace clothbench::kernels {

void VcyclePreconditioner::order_lines(Level& level, int d) {
  Lines& l = level.lines[d];
  const std::int64_t n = static_cast<std::int64_t>(level.i.size());
  // Direction 0: lines of constant j along i; direction 1: constant i along j.
  const std::vector<int>& key = d == 0 ? level.j : level.i;
  const std::vector<int>& along = d == 0 ? level.i : level.j;
  // Nodes by (key, along): stable counting sorts by `along`, then by `key` (a node is one grid
  // point, so this is the order of a comparison sort by the pair).
  std::vector<std::int64_t> by_along(static_cast<std::size_t>(n));
  l.order.resize(static_cast<std::size_t>(n));
  auto counting_sort = [n](const std::vector<int>& value, const std::int64_t* in,
                           std::int64_t* out) {
    std::vector<std::int64_t> first(1, 0);
    for (std::int64_t e = 0; e < n; ++e) {
      const auto v = static_cast<std::size_t>(value[in == nullptr ? e : in[e]]);
      if (first.size() < v + 2) first.resize(v + 2, 0);
      ++first[v + 1];
    }
    std::partial_sum(first.begin(), first.end(), first.begin());
    for (std::int64_t e = 0; e < n; ++e) {
      const std::int64_t a = in == nullptr ? e : in[e];
      out[first[static_cast<std::size_t>(value[a])]++] = a;
    }
  };
  counting_sort(along, nullptr, by_along.data());
  counting_sort(key, by_along.data(), l.order.data());
  l.start.clear();
  l.line_of.assign(static_cast<std::size_t>(n), -1);
  l.position.assign(static_cast<std::size_t>(n), -1);
  int current = -1;
  for (std::int64_t e = 0; e < n; ++e) {
    const std::int64_t a = l.order[e];
    if (key[a] != current) {
      current = key[a];
      l.start.push_back(e);
    }
    l.line_of[a] = static_cast<std::int64_t>(l.start.size()) - 1;
    l.position[a] = e - l.start.back();
  }
  const std::int64_t lines = static_cast<std::int64_t>(l.start.size());
  l.start.push_back(n);
  l.width.assign(static_cast<std::size_t>(lines), 0);
  l.below.assign(static_cast<std::size_t>(lines), {});
}

void VcyclePreconditioner::couple_line(Level& level, int d, std::int64_t line) {
  Lines& l = level.lines[d];
  std::vector<std::int64_t>& below = l.below[line];
  std::int64_t width = 2;
  for (std::int64_t e = l.start[line]; e < l.start[line + 1]; ++e) {
    const std::int64_t a = l.order[e];
    for (std::int64_t blk = level.a.start[a]; blk < level.a.start[a + 1]; ++blk) {
      const std::int64_t b = level.a.col[blk];
      const std::int64_t other = l.line_of[b];
      if (other == line) {
        width = std::max(width, 3 * std::abs(l.position[a] - l.position[b]) + 2);
      } else if (other < line) {
        below.push_back(other);
      }
    }
  }
  std::sort(below.begin(), below.end());
  below.erase(std::unique(below.begin(), below.end()), below.end());
  l.width[line] = static_cast<int>(width);
}

void VcyclePreconditioner::colour_lines(Level& level, int d) {
  Lines& l = level.lines[d];
  const std::int64_t lines = static_cast<std::int64_t>(l.width.size());
  // Greedy colours in line order: the first colour no coupled line before it has.
  std::vector<int> colour(static_cast<std::size_t>(lines), -1);
  std::vector<char> used;
  int colours = 0;
  for (std::int64_t line = 0; line < lines; ++line) {
    used.assign(static_cast<std::size_t>(colours) + 1, 0);
    for (const std::int64_t other : l.below[line]) used[colour[other]] = 1;
    int pick = 0;
    while (pick < colours && used[pick] != 0) ++pick;
    colour[line] = pick;
    colours = std::max(colours, pick + 1);
  }
  std::vector<std::vector<std::int64_t>>().swap(l.below);
  l.colour_start.assign(static_cast<std::size_t>(colours) + 1, 0);
  for (std::int64_t line = 0; line < lines; ++line) ++l.colour_start[colour[line] + 1];
  for (int c = 0; c < colours; ++c) l.colour_start[c + 1] += l.colour_start[c];
  l.by_colour.assign(static_cast<std::size_t>(lines), 0);
  std::vector<std::int64_t> fill(l.colour_start.begin(), l.colour_start.end() - 1);
  for (std::int64_t line = 0; line < lines; ++line) l.by_colour[fill[colour[line]]++] = line;
  l.band_start.assign(static_cast<std::size_t>(lines) + 1, 0);
  for (std::int64_t line = 0; line < lines; ++line) {
    l.band_start[line + 1] =
        l.band_start[line] + 3 * (l.start[line + 1] - l.start[line]) * (l.width[line] + 1);
  }
  l.band.assign(static_cast<std::size_t>(l.band_start.back()), 0.0f);
  l.ok.assign(static_cast<std::size_t>(lines), 0);
}

CLOTHBENCH_SCALAR_LOOPS void VcyclePreconditioner::factor_line(Level& level, int d,
                                                               std::int64_t line) {
  Lines& l = level.lines[d];
  const int w = l.width[line];
  const std::int64_t rows = 3 * (l.start[line + 1] - l.start[line]);
  // The band assembled and factored in double, then stored rounded to float.
  thread_local std::vector<double> work;
  work.assign(static_cast<std::size_t>(rows * (w + 1)), 0.0);
  double* band = work.data();
  const std::int64_t last = l.start[line + 1];
  for (std::int64_t e = l.start[line]; e < last; ++e) {
    if (e + kPrefetchAhead < last) prefetch_row(level.a, l.order[e + kPrefetchAhead]);
    const std::int64_t a = l.order[e];
    const std::int64_t pa = l.position[a];
    for (std::int64_t blk = level.a.start[a]; blk < level.a.start[a + 1]; ++blk) {
      const std::int64_t b = level.a.col[blk];
      if (l.line_of[b] != line) continue;
      const std::int64_t pb = l.position[b];
      if (pb > pa) continue;
      const float* block = level.a.value.data() + 9 * blk;
      for (int r = 0; r < 3; ++r) {
        const std::int64_t lr = 3 * pa + r;
        for (int c = 0; c < 3; ++c) {
          const std::int64_t lc = 3 * pb + c;
          if (lc <= lr) band[lr * (w + 1) + lc - lr + w] += block[3 * r + c];
        }
      }
    }
  }
  l.ok[line] = band::cholesky(band, rows, w) ? 1 : 0;
  store_rounded(work.data(), rows * (w + 1), l.band.data() + l.band_start[line]);
}

}  // namespace clothbench::kernels
