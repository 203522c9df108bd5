// Pareto fronts against a brute-force search; charts: size, where the markers land, colours per
// series name, axis ranges and ticks, degenerate data, and the PNG file.
#include "cli/plot.h"

#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"

namespace raywarp::plot {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- pareto_front ----

// The definition, O(n^2): i is on the front unless some j is <= in both coordinates and < in
// one. Sorted by x, ties by index.
std::vector<size_t> brute_front(const std::vector<double>& x, const std::vector<double>& y) {
  std::vector<size_t> front;
  for (size_t i = 0; i < x.size(); ++i) {
    if (std::isnan(x[i]) || std::isnan(y[i])) continue;
    bool beaten = false;
    for (size_t j = 0; j < x.size() && !beaten; ++j)
      beaten = !std::isnan(x[j]) && !std::isnan(y[j]) && x[j] <= x[i] && y[j] <= y[i] &&
               (x[j] < x[i] || y[j] < y[i]);
    if (!beaten) front.push_back(i);
  }
  std::stable_sort(front.begin(), front.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  return front;
}

using Indices = std::vector<size_t>;

TEST(ParetoFront, HandMadeSet) {
  // (3, 4) is beaten by (2, 3); (5, 1) by (4, 1), equal in y and worse in x.
  EXPECT_EQ(pareto_front({1, 2, 3, 4, 5}, {5, 3, 4, 1, 1}), (Indices{0, 1, 3}));
}

TEST(ParetoFront, EqualInOneCoordinateWorseInTheOtherIsDominated) {
  EXPECT_EQ(pareto_front({1, 1}, {2, 3}), (Indices{0}));
  EXPECT_EQ(pareto_front({1, 1}, {3, 2}), (Indices{1}));
  EXPECT_EQ(pareto_front({3, 2}, {1, 1}), (Indices{1}));
}

TEST(ParetoFront, DuplicatesAreAllOnTheFront) {
  EXPECT_EQ(pareto_front({2, 1, 1, 3}, {2, 4, 4, 1}), (Indices{1, 2, 0, 3}));
  EXPECT_EQ(pareto_front({1, 1, 1}, {1, 1, 1}), (Indices{0, 1, 2}));
}

TEST(ParetoFront, NaNPointsAreIgnored) {
  // Each NaN point would beat every other point if its NaN were read as small.
  EXPECT_EQ(pareto_front({kNaN, 0, 2, 3}, {0, kNaN, 2, 1}), (Indices{2, 3}));
  EXPECT_EQ(pareto_front({kNaN}, {kNaN}), Indices{});
}

TEST(ParetoFront, SinglePointEmptySetAndInfinities) {
  EXPECT_EQ(pareto_front({7}, {-3}), (Indices{0}));
  EXPECT_EQ(pareto_front({}, {}), Indices{});
  EXPECT_EQ(pareto_front({kInf, 1, -kInf}, {-kInf, 1, 5}), (Indices{2, 1, 0}));
}

TEST(ParetoFront, OutputIsSortedByXWhateverTheInputOrder) {
  EXPECT_EQ(pareto_front({30, 10, 20}, {1, 3, 2}), (Indices{1, 2, 0}));
}

TEST(ParetoFront, MismatchedLengthsThrow) { EXPECT_THROW(pareto_front({1, 2}, {1}), Error); }

// Random sets on a 6 x 6 integer grid, so that ties in x, in y and in both are common, with some
// NaN and infinite coordinates.
TEST(ParetoFront, MatchesTheDefinitionOnRandomSetsWithTies) {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> coord(0, 5), size(0, 25), special(0, 19);
  for (int trial = 0; trial < 500; ++trial) {
    const int n = size(rng);
    std::vector<double> x(n), y(n);
    for (int i = 0; i < n; ++i) {
      x[i] = coord(rng), y[i] = coord(rng);
      const int s = special(rng);
      if (s == 0) x[i] = kNaN;
      if (s == 1) y[i] = kNaN;
      if (s == 2) x[i] = kInf;
      if (s == 3) y[i] = -kInf;
    }
    ASSERT_EQ(pareto_front(x, y), brute_front(x, y)) << "trial " << trial;
  }
}

// ---- Axes ----

TEST(Axis, LogRangeCoversTheDataAndEndsOnHalfDecades) {
  Panel p;
  p.series.push_back({"s", {1.5, 40, 900}, {0.02, 3, 7e4}, true});
  const PanelLayout L = panel_layout(p, 480, 360);
  for (const Axis* a : {&L.x, &L.y}) {
    for (double end : {a->lo, a->hi})
      EXPECT_NEAR(2 * std::log10(end), std::round(2 * std::log10(end)), 1e-9);
  }
  EXPECT_LE(L.x.lo, 1.5);
  EXPECT_GE(L.x.hi, 900);
  EXPECT_LE(L.y.lo, 0.02);
  EXPECT_GE(L.y.hi, 7e4);
  // Padded: no point on the frame.
  EXPECT_LT(L.x.lo, 1.5);
  EXPECT_GT(L.y.hi, 7e4);
}

TEST(Axis, ToPixelIsLinearInLog10AndClampsToTheEnds) {
  Axis a;
  a.lo = 0.1, a.hi = 1000, a.log = true, a.pixel_lo = 300.5, a.pixel_hi = 20.5;
  EXPECT_DOUBLE_EQ(a.to_pixel(0.1), 300.5);
  EXPECT_DOUBLE_EQ(a.to_pixel(1000), 20.5);
  EXPECT_NEAR(a.to_pixel(10), 300.5 + (20.5 - 300.5) * 0.5, 1e-9);  // 2 of 4 decades
  EXPECT_DOUBLE_EQ(a.to_pixel(0), 300.5);
  EXPECT_DOUBLE_EQ(a.to_pixel(-5), 300.5);
  EXPECT_DOUBLE_EQ(a.to_pixel(1e9), 20.5);
  Axis b;
  b.lo = -2, b.hi = 2, b.pixel_lo = 10.5, b.pixel_hi = 50.5;
  EXPECT_DOUBLE_EQ(b.to_pixel(1), 40.5);
  EXPECT_DOUBLE_EQ(b.to_pixel(-7), 10.5);
}

TEST(Axis, YFloorIsTheLowerBoundAndValuesBelowItSitOnIt) {
  Panel p;
  p.y_floor = 1e-4;
  p.series.push_back({"s", {1, 2, 3}, {0, 1e-6, 0.3}, true});
  const PanelLayout L = panel_layout(p, 480, 360);
  EXPECT_DOUBLE_EQ(L.y.lo, 1e-4);
  EXPECT_GE(L.y.hi, 0.3);
  EXPECT_DOUBLE_EQ(L.y.to_pixel(0), L.y.pixel_lo);
  EXPECT_DOUBLE_EQ(L.y.to_pixel(1e-6), L.y.pixel_lo);
  EXPECT_LT(L.y.to_pixel(0.3), L.y.pixel_lo);
}

TEST(Axis, FrameAndAxesAgree) {
  Panel p;
  p.title = "t", p.x_label = "x", p.y_label = "y";
  p.series.push_back({"s", {1, 100}, {1, 100}, true});
  const PanelLayout L = panel_layout(p, 480, 360);
  EXPECT_LT(0, L.left);
  EXPECT_LT(L.left, L.right);
  EXPECT_LT(L.right, 480);
  EXPECT_LT(0, L.top);
  EXPECT_LT(L.top, L.bottom);
  EXPECT_LT(L.bottom, 360);
  EXPECT_DOUBLE_EQ(L.x.to_pixel(L.x.lo), L.left + 0.5);
  EXPECT_DOUBLE_EQ(L.x.to_pixel(L.x.hi), L.right + 0.5);
  EXPECT_DOUBLE_EQ(L.y.to_pixel(L.y.lo), L.bottom + 0.5);  // rows grow downwards
  EXPECT_DOUBLE_EQ(L.y.to_pixel(L.y.hi), L.top + 0.5);
}

std::vector<std::string> labels(const Axis& a) {
  std::vector<std::string> out;
  for (const Tick& t : axis_ticks(a))
    if (!t.label.empty()) out.push_back(t.label);
  return out;
}

TEST(Ticks, LogDecadesAreLabelledPlainlyNearOneAndWithExponentsBeyond) {
  Axis a;
  a.lo = 1e-4, a.hi = 1e3, a.log = true;
  EXPECT_EQ(labels(a),
            (std::vector<std::string>{"1e-4", "1e-3", "0.01", "0.1", "1", "10", "100", "1000"}));
  // Minor ticks 2..9 times each decade, unlabelled, inside the range.
  const std::vector<Tick> t = axis_ticks(a);
  EXPECT_EQ(t.size(), 8u + 7u * 8u);
  for (const Tick& tick : t) {
    EXPECT_GE(tick.value, a.lo * (1 - 1e-12));
    EXPECT_LE(tick.value, a.hi * (1 + 1e-12));
  }
}

TEST(Ticks, ANarrowLogRangeGetsTwoAndFiveTimesADecade) {
  Axis a;
  a.lo = std::pow(10.0, 0.5), a.hi = std::pow(10.0, 1.5), a.log = true;
  EXPECT_EQ(labels(a), (std::vector<std::string>{"5", "10", "20"}));
}

TEST(Ticks, LinearTicksAreRoundSteps) {
  Axis a;
  a.lo = -0.05, a.hi = 1.05;
  EXPECT_EQ(labels(a), (std::vector<std::string>{"0", "0.2", "0.4", "0.6", "0.8", "1.0"}));
  a.lo = -130, a.hi = 470;
  EXPECT_EQ(labels(a), (std::vector<std::string>{"-100", "0", "100", "200", "300", "400"}));
}

// ---- Charts ----

const Rgb kWhiteRgb{255, 255, 255};

Rgb pixel(const Image& im, int x, int y) {
  const uint8_t* p = &im.rgba[(static_cast<size_t>(y) * im.width + x) * 4];
  return {p[0], p[1], p[2]};
}

// Whether colour c is exactly at some pixel within `radius` of (x, y).
bool colour_near(const Image& im, int x, int y, Rgb c, int radius = 1) {
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) {
      const int px = x + dx, py = y + dy;
      if (px >= 0 && py >= 0 && px < im.width && py < im.height && pixel(im, px, py) == c)
        return true;
    }
  return false;
}

// Two series falling from top left to bottom right on log-log axes, markers only, so that a
// colour found at a point's pixel can only come from its marker.
Panel falling_panel(const std::string& a, const std::string& b) {
  Panel p;
  p.title = "error against frame time";
  p.x_label = "frame time (ms)";
  p.y_label = "pixels over";
  p.series.push_back({a, {1, 10, 100, 1000}, {1000, 100, 10, 1}, false});
  p.series.push_back({b, {2, 30, 400}, {2000, 60, 0.5}, false});
  return p;
}

TEST(Chart, HasTheRequestedSize) {
  const Panel p = falling_panel("a", "b");
  Image im = render_chart({p, p, p}, 2, 300, 200);
  EXPECT_EQ(im.width, 600);
  EXPECT_EQ(im.height, 400);
  EXPECT_EQ(im.rgba.size(), 600u * 400u * 4u);
  // Fewer panels than columns: no empty column.
  im = render_chart({p}, 3, 300, 200);
  EXPECT_EQ(im.width, 300);
  EXPECT_EQ(im.height, 200);
  // No panels: one empty panel.
  im = render_chart({}, 2, 120, 90);
  EXPECT_EQ(im.width, 120);
  EXPECT_EQ(im.height, 90);
}

// Mostly white, as a chart is, but with ink on more than 1% of it, each series' colour on at
// least its markers (7 px discs or 6 px squares: 30 px or more each), and opaque everywhere.
TEST(Chart, IsNotBlankAndIsOpaque) {
  const Panel p = falling_panel("a", "b");
  const Image im = render_chart({p}, 1);
  const std::vector<Rgb> colours = series_colours({p})[0];
  long white = 0;
  std::vector<long> in_colour(colours.size(), 0);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      white += pixel(im, x, y) == kWhiteRgb;
      for (size_t s = 0; s < colours.size(); ++s) in_colour[s] += pixel(im, x, y) == colours[s];
    }
  EXPECT_LT(white, static_cast<long>(im.width) * im.height * 99 / 100);
  for (size_t s = 0; s < colours.size(); ++s)
    EXPECT_GE(in_colour[s], 30 * static_cast<long>(p.series[s].x.size())) << "series " << s;
  for (size_t i = 3; i < im.rgba.size(); i += 4) ASSERT_EQ(im.rgba[i], 255);
}

// Each point's marker, in its series' colour, lies at the pixel the panel's axes give, in
// whichever panel of the grid; the mirror image of the point (y flipped) does not have it.
TEST(Chart, MarkersLandWhereTheAxesPutThem) {
  const std::vector<Panel> panels{falling_panel("linear", "jacobian"),
                                  falling_panel("jacobian", "threshold")};
  const int w = 400, h = 300;
  const Image im = render_chart(panels, 2, w, h);
  const std::vector<std::vector<Rgb>> colours = series_colours(panels);
  for (size_t k = 0; k < panels.size(); ++k) {
    const PanelLayout L = panel_layout(panels[k], w, h);
    const int ox = static_cast<int>(k) * w;
    for (size_t s = 0; s < panels[k].series.size(); ++s) {
      const Series& series = panels[k].series[s];
      for (size_t i = 0; i < series.x.size(); ++i) {
        const double px = L.x.to_pixel(series.x[i]), py = L.y.to_pixel(series.y[i]);
        const int ix = ox + static_cast<int>(std::floor(px)), iy = static_cast<int>(std::floor(py));
        EXPECT_TRUE(colour_near(im, ix, iy, colours[k][s]))
            << "panel " << k << " series " << s << " point " << i << " at " << ix << ", " << iy;
        const int mirrored = static_cast<int>(std::floor(L.y.pixel_lo + L.y.pixel_hi - py));
        if (std::abs(mirrored - iy) > 12) {
          EXPECT_FALSE(colour_near(im, ix, mirrored, colours[k][s], 2))
              << "panel " << k << " series " << s << " point " << i << " mirrored";
        }
      }
    }
  }
}

TEST(Chart, ASeriesKeepsItsColourByNameAcrossPanels) {
  const std::vector<Panel> panels{falling_panel("linear", "jacobian"),
                                  falling_panel("jacobian", "threshold")};
  const std::vector<std::vector<Rgb>> c = series_colours(panels);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[1][0], c[0][1]);  // "jacobian"
  EXPECT_FALSE(c[1][1] == c[0][0]);
  EXPECT_FALSE(c[1][1] == c[0][1]);
}

// The palette's first colours are told apart from each other and from the white background: at
// least 60 apart in RGB (a tenth of the cube's diagonal is 44), none lighter than 235 in all.
TEST(Chart, PaletteHasDistinctColoursThatShowOnWhite) {
  Panel p;
  for (int i = 0; i < 10; ++i)
    p.series.push_back({std::string(1, static_cast<char>('a' + i)), {1}, {1}, true});
  const std::vector<Rgb> c = series_colours({p})[0];
  for (size_t i = 0; i < c.size(); ++i) {
    EXPECT_LT(std::min({c[i].r, c[i].g, c[i].b}), 235);
    for (size_t j = 0; j < i; ++j) {
      const double d = std::hypot(c[i].r - c[j].r, c[i].g - c[j].g, c[i].b - c[j].b);
      EXPECT_GT(d, 60) << "colours " << i << " and " << j;
    }
  }
}

// A connected series draws its line between the points: the midpoint of a segment (in pixels)
// has the series' colour.
TEST(Chart, LinesJoinThePointsInXOrder) {
  Panel p;
  p.log_x = p.log_y = false;
  // Given out of order: joined in x order, the line passes through (2, 2) halfway between
  // (1, 1) and (3, 3); joined in the given order it would not.
  p.series.push_back({"s", {3, 1, 5}, {3, 1, 1}, true});
  const Image im = render_chart({p}, 1, 400, 300);
  const PanelLayout L = panel_layout(p, 400, 300);
  const Rgb c = series_colours({p})[0][0];
  const int x = static_cast<int>(std::floor(L.x.to_pixel(2))),
            y = static_cast<int>(std::floor(L.y.to_pixel(2)));
  EXPECT_TRUE(colour_near(im, x, y, c));
}

// The front's staircase and rings are black: dark pixels at each front point's ring.
TEST(Chart, ParetoFrontIsDrawnInBlack) {
  Panel p = falling_panel("a", "b");
  p.front = {{1, 1000}, {10, 100}, {100, 10}};
  const Image im = render_chart({p}, 1, 480, 360);
  const PanelLayout L = panel_layout(p, 480, 360);
  for (const auto& [fx, fy] : p.front) {
    const double px = L.x.to_pixel(fx), py = L.y.to_pixel(fy);
    // The ring's radius is 6.5 px, 2 px wide: its bottom passes 6.5 px below the point.
    const int x = static_cast<int>(std::floor(px)), y = static_cast<int>(std::floor(py + 6.5));
    EXPECT_TRUE(colour_near(im, x, y, Rgb{0, 0, 0})) << fx << ", " << fy;
  }
}

long dark_pixels(const Image& im) {
  long n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const Rgb c = pixel(im, x, y);
      n += c.r < 200 || c.g < 200 || c.b < 200;
    }
  return n;
}

// Degenerate panels render at their size, with something drawn, and throw nothing.
TEST(Chart, DegenerateDataRenders) {
  std::vector<Panel> cases;
  cases.emplace_back();  // no series at all
  Panel one;
  one.series.push_back({"one", {5}, {0.2}, true});
  cases.push_back(one);
  Panel equal;
  equal.series.push_back({"equal", {3, 3, 3}, {7, 7, 7}, true});
  cases.push_back(equal);
  Panel bad;
  bad.series.push_back({"bad", {kNaN, 1, kInf, 2, -kInf}, {1, kNaN, 3, kInf, 4}, true});
  bad.front = {{kNaN, 1}, {kInf, kInf}};
  cases.push_back(bad);
  Panel nonpositive;
  nonpositive.series.push_back({"nonpositive", {0, -1, 2}, {-3, 0, 0}, true});
  cases.push_back(nonpositive);
  Panel zero_linear = equal;
  zero_linear.log_x = zero_linear.log_y = false;
  zero_linear.series[0].y = {0, 0, 0};
  cases.push_back(zero_linear);
  Panel huge;
  huge.log_x = huge.log_y = false;
  huge.series.push_back({"huge", {-1.7e308, 1.7e308}, {1e-308, -1e308}, true});
  cases.push_back(huge);
  Panel tiny_log;
  tiny_log.series.push_back({"tiny", {1e-320, 1e308}, {4.9e-324, 1.7e308}, true});
  tiny_log.y_floor = 1e-310;
  cases.push_back(tiny_log);
  Panel text;
  text.title = "caf\xc3\xa9 \t\n\x7f";  // non-ASCII bytes and control characters
  text.series.push_back({"\xce\xbcs", {1, 2}, {2, 1}, false});
  text.series.push_back({"", {1, 2}, {1, 2}, true});
  cases.push_back(text);
  Panel many;
  for (int i = 0; i < 25; ++i)
    many.series.push_back({"series " + std::to_string(i), {1.0 + i}, {1.0 + i}, i % 2 == 0});
  cases.push_back(many);

  for (size_t k = 0; k < cases.size(); ++k) {
    for (auto [w, h] : {std::pair{480, 360}, std::pair{60, 40}, std::pair{3, 2}, std::pair{1, 1}}) {
      Image im;
      ASSERT_NO_THROW(im = render_chart({cases[k]}, 1, w, h)) << "case " << k << " " << w;
      ASSERT_EQ(im.width, w);
      ASSERT_EQ(im.height, h);
      if (w >= 60) {
        EXPECT_GT(dark_pixels(im), 0) << "case " << k << " " << w;
      }
    }
  }
}

// An empty panel still has its frame and, inside it, the words "no data".
TEST(Chart, EmptyPanelSaysNoData) {
  Panel p;
  const Image im = render_chart({p}, 1, 480, 360);
  const PanelLayout L = panel_layout(p, 480, 360);
  long inked = 0;  // darker than the grid, strictly inside the frame
  for (int y = L.top + 1; y < L.bottom; ++y)
    for (int x = L.left + 1; x < L.right; ++x) inked += pixel(im, x, y).r < 200;
  EXPECT_GT(inked, 20);
  EXPECT_TRUE(colour_near(im, L.left, (L.top + L.bottom) / 2, Rgb{51, 51, 51}, 0));  // frame
}

TEST(Chart, BadArgumentsThrow) {
  Panel p;
  EXPECT_THROW(render_chart({p}, 0), Error);
  EXPECT_THROW(render_chart({p}, 1, 0, 100), Error);
  EXPECT_THROW(render_chart({p}, 1, 100, -1), Error);
  EXPECT_THROW(render_chart({p}, 1, 100000, 100000), Error);
  p.series.push_back({"s", {1, 2}, {1}, true});
  EXPECT_THROW(render_chart({p}, 1), Error);
}

TEST(Chart, WritesAPngThatReadsBackTheSame) {
  std::random_device rd;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("raywarp_plot_test_" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "chart.png").string();
  const Image im = render_chart({falling_panel("a", "b")}, 1, 320, 240);
  write_png(path, im);
  int w = 0, h = 0, channels = 0;
  uint8_t* data = stbi_load(path.c_str(), &w, &h, &channels, 4);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 320);
  EXPECT_EQ(h, 240);
  EXPECT_TRUE(std::equal(im.rgba.begin(), im.rgba.end(), data));
  stbi_image_free(data);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace raywarp::plot
