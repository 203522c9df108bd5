#include "cli/plot.h"

#include <stb/stb_easy_font.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

#include "base/error.h"

namespace raywarp::plot {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Text is stb_easy_font scaled by kTextScale: its capitals are 7 font pixels tall, descenders
// reach 2 more, and each character advances 6 (digits) or less. A legend that would cover data
// may fall back to scale 1.
constexpr int kTextScale = 2;
constexpr int kFontCap = 7;
constexpr int kCapHeight = kFontCap * kTextScale;
constexpr int kLineHeight = (kFontCap + 2) * kTextScale;  // with descenders
constexpr int kPad = 6;        // between a panel's edge and its text, and between text lines
constexpr int kMajorTick = 5;  // tick lengths, outside the plot area
constexpr int kMinorTick = 3;
constexpr int kLabelGap = 4;  // between a tick and its label
constexpr double kLineWidth = 2.0;
constexpr double kFrontWidth = 3.0;
constexpr double kDiscRadius = 3.5;  // a 7 px disc
constexpr double kSquareHalf = 3.0;  // a 6 px square
constexpr double kRingRadius = 6.5;  // the front's hollow circle, around a series' marker
constexpr double kRingWidth = 2.0;
// Log-axis data beyond 1e+-307 would put pow(10, snapped bound) out of the normal doubles;
// linear-axis data beyond 1e300 would make the padded span overflow.
constexpr double kMaxLogDecade = 307;
constexpr double kMaxLinear = 1e300;
constexpr long kMaxPixels = 1L << 26;

const Rgb kWhite{255, 255, 255};
const Rgb kBlack{0, 0, 0};
const Rgb kText{34, 34, 34};
const Rgb kFrame{51, 51, 51};
const Rgb kGrid{230, 230, 230};
const Rgb kLegendBorder{160, 160, 160};
const Rgb kNoData{140, 140, 140};

// matplotlib's "tab10": ten colours told apart on white, and by most colour-blind readers in
// pairs of neighbours.
constexpr std::array<Rgb, 10> kPalette{{{31, 119, 180},
                                        {255, 127, 14},
                                        {44, 160, 44},
                                        {214, 39, 40},
                                        {148, 103, 189},
                                        {140, 86, 75},
                                        {227, 119, 194},
                                        {127, 127, 127},
                                        {188, 189, 34},
                                        {23, 190, 207}}};

struct Point {
  double x = 0, y = 0;
};

// A double to an int in [lo, hi], NaN to lo: pixel loops take their bounds from here, so that
// no coordinate, however far off, reaches an out-of-range conversion.
int clamp_to_int(double v, int lo, int hi) {
  if (!(v >= lo)) return lo;
  if (v >= hi) return hi;
  return static_cast<int>(v);
}

// Drawing into an Image, clipped to a rectangle inside it.
struct Canvas {
  Image& image;
  int x0, y0, x1, y1;  // half-open clip rectangle, within the image

  Canvas(Image& im, int ax, int ay, int bx, int by)
      : image(im),
        x0(std::clamp(ax, 0, im.width)),
        y0(std::clamp(ay, 0, im.height)),
        x1(std::clamp(bx, x0, im.width)),
        y1(std::clamp(by, y0, im.height)) {}

  // The same image, clipped further.
  Canvas clipped(int ax, int ay, int bx, int by) const {
    return Canvas(image, std::max(ax, x0), std::max(ay, y0), std::min(bx, x1), std::min(by, y1));
  }

  // Mixes `c` over pixel (x, y) with opacity alpha in [0, 1].
  void blend(int x, int y, Rgb c, double alpha) {
    if (x < x0 || x >= x1 || y < y0 || y >= y1 || !(alpha > 0)) return;
    uint8_t* p = &image.rgba[(static_cast<size_t>(y) * image.width + x) * 4];
    const double a = std::min(alpha, 1.0);
    const std::array<uint8_t, 3> src{c.r, c.g, c.b};
    for (int k = 0; k < 3; ++k)
      p[k] = static_cast<uint8_t>(std::lround(src[k] * a + p[k] * (1 - a)));
    p[3] = 255;
  }

  // Fills the half-open pixel rectangle [ax, bx) x [ay, by).
  void fill_rect(int ax, int ay, int bx, int by, Rgb c) {
    for (int y = std::max(ay, y0); y < std::min(by, y1); ++y)
      for (int x = std::max(ax, x0); x < std::min(bx, x1); ++x) blend(x, y, c, 1.0);
  }

  // Calls cover(px, py) -> opacity for each pixel centre in the box [ax, bx] x [ay, by]
  // (continuous coordinates) that lies in the clip rectangle, and blends `c` with it.
  template <typename Coverage>
  void shade(double ax, double ay, double bx, double by, Rgb c, Coverage cover) {
    const int xa = clamp_to_int(std::floor(ax), x0, x1), xb = clamp_to_int(std::ceil(bx), x0, x1);
    const int ya = clamp_to_int(std::floor(ay), y0, y1), yb = clamp_to_int(std::ceil(by), y0, y1);
    for (int y = ya; y < yb; ++y)
      for (int x = xa; x < xb; ++x) blend(x, y, c, cover(x + 0.5, y + 0.5));
  }
};

bool finite(Point p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// Opacity of a pixel whose centre is at distance d from the middle of a stroke of half width r:
// 1 inside, 0 outside, a linear ramp one pixel wide across the edge.
double edge_coverage(double d, double r) { return std::clamp(r + 0.5 - d, 0.0, 1.0); }

double distance_to_segment(Point p, Point a, Point b) {
  const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

// A polyline `width` pixels wide. Coverage is the maximum over its segments, taken before
// blending, so joints are not blended twice and show no darker knots.
void draw_polyline(Canvas& canvas, const std::vector<Point>& points, double width, Rgb c) {
  const double r = width / 2;
  double ax = kInf, ay = kInf, bx = -kInf, by = -kInf;
  for (Point p : points)
    if (finite(p)) {
      ax = std::min(ax, p.x), ay = std::min(ay, p.y);
      bx = std::max(bx, p.x), by = std::max(by, p.y);
    }
  if (points.size() < 2 || !(ax <= bx)) return;
  const int xa = clamp_to_int(std::floor(ax - r - 1), canvas.x0, canvas.x1);
  const int xb = clamp_to_int(std::ceil(bx + r + 1), canvas.x0, canvas.x1);
  const int ya = clamp_to_int(std::floor(ay - r - 1), canvas.y0, canvas.y1);
  const int yb = clamp_to_int(std::ceil(by + r + 1), canvas.y0, canvas.y1);
  if (xa >= xb || ya >= yb) return;
  const int w = xb - xa;
  std::vector<float> cover(static_cast<size_t>(w) * (yb - ya), 0.0f);
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    const Point a = points[i], b = points[i + 1];
    if (!finite(a) || !finite(b)) continue;
    const int sxa = clamp_to_int(std::floor(std::min(a.x, b.x) - r - 1), xa, xb);
    const int sxb = clamp_to_int(std::ceil(std::max(a.x, b.x) + r + 1), xa, xb);
    const int sya = clamp_to_int(std::floor(std::min(a.y, b.y) - r - 1), ya, yb);
    const int syb = clamp_to_int(std::ceil(std::max(a.y, b.y) + r + 1), ya, yb);
    for (int y = sya; y < syb; ++y)
      for (int x = sxa; x < sxb; ++x) {
        float& f = cover[static_cast<size_t>(y - ya) * w + (x - xa)];
        f = std::max(
            f, static_cast<float>(edge_coverage(distance_to_segment({x + 0.5, y + 0.5}, a, b), r)));
      }
  }
  for (int y = ya; y < yb; ++y)
    for (int x = xa; x < xb; ++x)
      canvas.blend(x, y, c, cover[static_cast<size_t>(y - ya) * w + (x - xa)]);
}

void fill_disc(Canvas& canvas, Point p, double r, Rgb c) {
  canvas.shade(p.x - r - 1, p.y - r - 1, p.x + r + 1, p.y + r + 1, c,
               [&](double x, double y) { return edge_coverage(std::hypot(x - p.x, y - p.y), r); });
}

void draw_ring(Canvas& canvas, Point p, double r, double width, Rgb c) {
  const double outer = r + width / 2 + 1;
  canvas.shade(p.x - outer, p.y - outer, p.x + outer, p.y + outer, c, [&](double x, double y) {
    return edge_coverage(std::abs(std::hypot(x - p.x, y - p.y) - r), width / 2);
  });
}

// Pixels whose centres lie within `half` of p in both coordinates; no ramp, so edges stay sharp.
void fill_square(Canvas& canvas, Point p, double half, Rgb c) {
  canvas.shade(p.x - half - 1, p.y - half - 1, p.x + half + 1, p.y + half + 1, c,
               [&](double x, double y) {
                 return std::abs(x - p.x) <= half && std::abs(y - p.y) <= half ? 1.0 : 0.0;
               });
}

enum class Marker { kDisc, kSquare };

void draw_marker(Canvas& canvas, Point p, Marker m, Rgb c) {
  if (!finite(p)) return;
  if (m == Marker::kDisc)
    fill_disc(canvas, p, kDiscRadius, c);
  else
    fill_square(canvas, p, kSquareHalf, c);
}

// ---- Text ----

// stb_easy_font indexes its tables by character - 32, so anything outside printable ASCII would
// read outside them: it becomes '?'.
std::string printable(const std::string& s) {
  std::string out = s;
  for (char& ch : out)
    if (ch < 32 || ch > 126) ch = '?';
  return out;
}

// Width in pixels of the inked part of a one-line text (stb counts one trailing pixel of spacing).
int text_width(const std::string& s, int scale = kTextScale) {
  if (s.empty()) return 0;
  std::string t = printable(s);
  return std::max(0, stb_easy_font_width(t.data()) - 1) * scale;
}

// Draws one line of text with the top-left corner of its capitals' box at (x, y). `upward` turns
// it a quarter counter-clockwise, to read from bottom to top: its box is then kFontCap * scale
// wide and text_width tall, with the same top-left corner.
void draw_text(Canvas& canvas, int x, int y, const std::string& s, Rgb c, bool upward = false,
               int scale = kTextScale) {
  if (s.empty()) return;
  std::string t = printable(s);
  // At most 14 segments a character, each a quad of 4 vertices of 4 floats (x, y, z, colour).
  std::vector<float> quads(t.size() * 14 * 16 + 16);
  const int n = stb_easy_font_print(0, 0, t.data(), nullptr, quads.data(),
                                    static_cast<int>(quads.size() * sizeof(float)));
  const int font_width = std::max(0, stb_easy_font_width(t.data()) - 1);
  for (int q = 0; q < n; ++q) {
    const float* v = &quads[static_cast<size_t>(q) * 16];
    // Vertices 0 and 2 are opposite corners of an axis-aligned quad on whole font pixels.
    const int qx0 = static_cast<int>(std::min(v[0], v[8])),
              qx1 = static_cast<int>(std::max(v[0], v[8]));
    const int qy0 = static_cast<int>(std::min(v[1], v[9])),
              qy1 = static_cast<int>(std::max(v[1], v[9]));
    if (!upward)
      canvas.fill_rect(x + qx0 * scale, y + qy0 * scale, x + qx1 * scale, y + qy1 * scale, c);
    else
      canvas.fill_rect(x + qy0 * scale, y + (font_width - qx1) * scale, x + qy1 * scale,
                       y + (font_width - qx0) * scale, c);
  }
}

// Text centred horizontally on cx.
void draw_text_centred(Canvas& canvas, double cx, int y, const std::string& s, Rgb c) {
  draw_text(canvas, static_cast<int>(std::lround(cx - text_width(s) / 2.0)), y, s, c);
}

// ---- Axes ----

// The smallest and largest of the values added.
struct Extent {
  double lo = kInf, hi = -kInf;
  void add(double v) { lo = std::min(lo, v), hi = std::max(hi, v); }
  bool empty() const { return !(lo <= hi); }
};

// Axis range of finite data; on a log axis only values > 0 count (the others sit at the
// minimum), and `floor` > 0 fixes the minimum.
Extent data_extent(const std::vector<double>& values, bool log) {
  Extent e;
  for (double v : values) {
    if (!std::isfinite(v) || (log && v <= 0)) continue;
    e.add(log ? std::clamp(std::log10(v), -kMaxLogDecade, kMaxLogDecade)
              : std::clamp(v, -kMaxLinear, kMaxLinear));
  }
  return e;
}

// A log axis from data extent e (in log10), padded by 4% of its span and widened to half
// decades, so that no point sits on the frame and the ends are 1, 3.16 or 10 times a decade.
// A single value gets a decade around it. `floor` > 0 is the axis minimum.
std::pair<double, double> log_range(Extent e, double floor) {
  const bool fixed_lo = floor > 0 && std::isfinite(floor);
  if (fixed_lo) {
    const double a = std::clamp(std::log10(floor), -kMaxLogDecade, kMaxLogDecade - 1);
    double b = e.empty() ? a : std::max(e.hi, a);
    b = b - a < 1e-9 ? a + 1 : std::ceil(2 * (b + 0.04 * (b - a))) / 2;
    return {floor, std::pow(10.0, std::min(b, kMaxLogDecade))};
  }
  if (e.empty()) return {1.0, 10.0};
  double a = e.lo, b = e.hi;
  if (b - a < 1e-9) {
    a -= 0.5, b += 0.5;
  } else {
    const double pad = 0.04 * (b - a);
    a -= pad, b += pad;
  }
  a = std::max(std::floor(2 * a) / 2, -kMaxLogDecade);
  b = std::min(std::ceil(2 * b) / 2, kMaxLogDecade);
  return {std::pow(10.0, a), std::pow(10.0, b)};
}

// A linear axis from data extent e, padded by 5% of its span; a single value v gets +-10% of v
// around it (+-1 around 0).
std::pair<double, double> linear_range(Extent e) {
  if (e.empty()) return {0.0, 1.0};
  const double span = e.hi - e.lo;
  const double scale = std::max(std::abs(e.lo), std::abs(e.hi));
  if (span <= 1e-12 * scale || span == 0) {
    const double pad = scale > 0 ? 0.1 * scale : 1.0;
    return {e.lo - pad, e.hi + pad};
  }
  return {e.lo - 0.05 * span, e.hi + 0.05 * span};
}

Axis make_axis(const std::vector<double>& values, bool log, double floor) {
  Axis axis;
  axis.log = log;
  const Extent e = data_extent(values, log);
  std::tie(axis.lo, axis.hi) = log ? log_range(e, floor) : linear_range(e);
  return axis;
}

// The label of m * 10^k, m in 1..9: "0.05", "1", "200", or "1e-3", "5e4" beyond that.
std::string decade_label(int m, int k) {
  const std::string digit = std::to_string(m);
  if (k >= 0 && k <= 3) return digit + std::string(static_cast<size_t>(k), '0');
  if (k == -1) return "0." + digit;
  if (k == -2) return "0.0" + digit;
  return digit + "e" + std::to_string(k);
}

std::vector<Tick> log_ticks(const Axis& axis) {
  const double a = std::log10(axis.lo), b = std::log10(axis.hi);
  if (!std::isfinite(a) || !std::isfinite(b) || !(a < b)) return {};
  const int k0 = static_cast<int>(std::ceil(a - 1e-9)), k1 = static_cast<int>(std::floor(b + 1e-9));
  const int decades = k1 - k0 + 1;
  auto inside = [&](double lg) { return lg >= a - 1e-9 && lg <= b + 1e-9; };
  std::vector<Tick> ticks;
  if (decades >= 2) {
    // Label about eight decades at most, at multiples of a stride so that labels do not move
    // when the range grows by one decade.
    const int stride = (decades + 7) / 8;
    for (int k = k0; k <= k1; ++k) {
      ticks.push_back({std::pow(10.0, k), k % stride == 0 ? decade_label(1, k) : ""});
      if (decades > 8) continue;
      for (int m = 2; m <= 9; ++m)
        if (inside(k + std::log10(m))) ticks.push_back({m * std::pow(10.0, k), ""});
    }
    // Minor ticks below the first decade.
    if (decades <= 8)
      for (int m = 2; m <= 9; ++m)
        if (inside(k0 - 1 + std::log10(m))) ticks.push_back({m * std::pow(10.0, k0 - 1), ""});
  } else {
    // Less than two decades: label 1, 2 and 5 times a decade, or every multiple if that still
    // gives fewer than two labels.
    int labelled = 0;
    for (int k = k0 - 1; k <= k1; ++k)
      for (int m : {1, 2, 5}) labelled += inside(k + std::log10(m));
    for (int k = k0 - 1; k <= k1; ++k)
      for (int m = 1; m <= 9; ++m) {
        if (!inside(k + std::log10(m))) continue;
        const bool label = labelled >= 2 ? (m == 1 || m == 2 || m == 5) : true;
        ticks.push_back({m * std::pow(10.0, k), label ? decade_label(m, k) : ""});
      }
  }
  std::sort(ticks.begin(), ticks.end(),
            [](const Tick& p, const Tick& q) { return p.value < q.value; });
  return ticks;
}

// The label of v, a multiple of step: as many decimals as step needs, or the shortest
// exponent form outside [1e-4, 1e6).
std::string linear_label(double v, double step) {
  char buf[64];
  const double mag = std::max(std::abs(v), step);
  if (mag >= 1e6 || step < 1e-4) {
    std::snprintf(buf, sizeof buf, "%.3g", v);
  } else {
    const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  }
  std::string s = buf;
  if (s.find_first_not_of("-0.") == std::string::npos) s = "0";  // no "-0" or "-0.00"
  return s;
}

std::vector<Tick> linear_ticks(const Axis& axis) {
  const double span = axis.hi - axis.lo;
  if (!std::isfinite(span) || !(span > 0)) return {};
  // A step of 1, 2 or 5 times a power of ten giving about five ticks.
  const double raw = span / 5;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / p;
  const double step = (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * p;
  if (!(step > 0) || !std::isfinite(step)) return {};
  const double first = std::ceil(axis.lo / step - 1e-9), last = std::floor(axis.hi / step + 1e-9);
  std::vector<Tick> ticks;
  for (double k = first; k <= last && ticks.size() < 20; ++k) {
    const double v = k * step;
    ticks.push_back({v, linear_label(v, step)});
  }
  return ticks;
}

// ---- Panels ----

// All finite values of one coordinate in a panel, series and front.
std::vector<double> panel_values(const Panel& panel, bool x) {
  std::vector<double> v;
  for (const Series& s : panel.series) {
    const std::vector<double>& c = x ? s.x : s.y;
    const size_t n = std::min(s.x.size(), s.y.size());
    for (size_t i = 0; i < n; ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) v.push_back(c[i]);
  }
  for (const auto& [fx, fy] : panel.front)
    if (std::isfinite(fx) && std::isfinite(fy)) v.push_back(x ? fx : fy);
  return v;
}

int widest_label(const std::vector<Tick>& ticks) {
  int w = 0;
  for (const Tick& t : ticks) w = std::max(w, text_width(t.label));
  return w;
}

// Palette slot of each series, [panel][series]: a new slot per name met for the first time.
std::vector<std::vector<size_t>> colour_slots(const std::vector<Panel>& panels) {
  std::map<std::string, size_t> slot_of;
  size_t next = 0;
  std::vector<std::vector<size_t>> slots;
  for (const Panel& p : panels) {
    slots.emplace_back();
    for (const Series& s : p.series) {
      if (s.name.empty()) {
        slots.back().push_back(next++);
        continue;
      }
      auto [it, inserted] = slot_of.try_emplace(s.name, next);
      if (inserted) ++next;
      slots.back().push_back(it->second);
    }
  }
  return slots;
}

Rgb colour_of(size_t slot) { return kPalette[slot % kPalette.size()]; }

// Discs and squares alternate along the palette, and swap on each pass through it, so that
// slots 0 and 10, which share a colour, differ in shape.
Marker marker_of(size_t slot) {
  return (slot + slot / kPalette.size()) % 2 == 0 ? Marker::kDisc : Marker::kSquare;
}

struct LegendEntry {
  std::string name;
  Rgb colour;
  Marker marker = Marker::kDisc;
  bool line = true;
  bool front = false;
};

// A pixel rectangle [x0, x1) x [y0, y1).
struct Box {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool contains(Point p) const { return p.x >= x0 && p.x < x1 && p.y >= y0 && p.y < y1; }
};

// A legend's size and where it goes.
struct Legend {
  int scale = kTextScale;  // of its text
  Box box;
  int row() const { return kFontCap * scale + 4 + 2 * scale; }  // between entries' tops
  // The front's ring, smaller in the small legend so that it stays within its row.
  double ring_radius() const { return std::min(kRingRadius, row() / 2.0 - kRingWidth / 2 - 0.5); }
  int swatch() const { return 12 + 8 * scale; }  // width of an entry's line sample
};

// A legend of the entries at text scale `scale`, with its top-left corner at (0, 0).
Legend legend_of_size(const std::vector<LegendEntry>& entries, int scale) {
  Legend g;
  g.scale = scale;
  int w = 0;
  for (const LegendEntry& e : entries) w = std::max(w, text_width(e.name, scale));
  const int n = static_cast<int>(entries.size());
  g.box = {0, 0, kPad + g.swatch() + kPad + w + kPad,
           kPad + n * g.row() - (g.row() - kFontCap * scale) + kPad};
  return g;
}

// The corner of the plot area (top right, top left, bottom left, bottom right, in that order of
// preference) where the legend covers the fewest of `marks` (markers, and samples along lines),
// and how many it covers there. The full-size legend goes where it covers nothing, else the
// small one, else whichever covers fewer.
std::pair<Box, long> best_corner(const Box& size, const PanelLayout& L,
                                 const std::vector<Point>& marks) {
  const int inset = 8, w = size.x1, h = size.y1;
  const std::array<Box, 4> corners{{
      {L.right - inset - w, L.top + inset, L.right - inset, L.top + inset + h},
      {L.left + inset, L.top + inset, L.left + inset + w, L.top + inset + h},
      {L.left + inset, L.bottom - inset - h, L.left + inset + w, L.bottom - inset},
      {L.right - inset - w, L.bottom - inset - h, L.right - inset, L.bottom - inset},
  }};
  std::pair<Box, long> best{corners[0], std::numeric_limits<long>::max()};
  for (const Box& b : corners) {
    // A mark counts if any of a marker drawn there would be under the box.
    const int m = static_cast<int>(std::ceil(kDiscRadius));
    const Box grown{b.x0 - m, b.y0 - m, b.x1 + m, b.y1 + m};
    const long count =
        std::count_if(marks.begin(), marks.end(), [&](Point p) { return grown.contains(p); });
    if (count < best.second) best = {b, count};
  }
  return best;
}

Legend place_legend(const std::vector<LegendEntry>& entries, const PanelLayout& L,
                    const std::vector<Point>& marks) {
  Legend large = legend_of_size(entries, kTextScale), small = legend_of_size(entries, 1);
  long covered_large = 0, covered_small = 0;
  std::tie(large.box, covered_large) = best_corner(large.box, L, marks);
  if (covered_large == 0) return large;
  std::tie(small.box, covered_small) = best_corner(small.box, L, marks);
  return covered_small < covered_large ? small : large;
}

void draw_legend(Canvas& canvas, const Legend& g, const std::vector<LegendEntry>& entries) {
  const Box& b = g.box;
  canvas.fill_rect(b.x0, b.y0, b.x1, b.y1, kWhite);
  canvas.fill_rect(b.x0, b.y0, b.x1, b.y0 + 1, kLegendBorder);
  canvas.fill_rect(b.x0, b.y1 - 1, b.x1, b.y1, kLegendBorder);
  canvas.fill_rect(b.x0, b.y0, b.x0 + 1, b.y1, kLegendBorder);
  canvas.fill_rect(b.x1 - 1, b.y0, b.x1, b.y1, kLegendBorder);
  int y = b.y0 + kPad;
  const double sx = b.x0 + kPad, sw = g.swatch();
  for (const LegendEntry& e : entries) {
    const double cy = y + kFontCap * g.scale / 2.0;
    const Point mid{sx + sw / 2, cy};
    if (e.front) {
      draw_polyline(canvas, {{sx, cy}, {sx + sw, cy}}, kFrontWidth, kBlack);
      draw_ring(canvas, mid, g.ring_radius(), kRingWidth, kBlack);
    } else {
      if (e.line) draw_polyline(canvas, {{sx, cy}, {sx + sw, cy}}, kLineWidth, e.colour);
      draw_marker(canvas, mid, e.marker, e.colour);
    }
    draw_text(canvas, b.x0 + kPad + g.swatch() + kPad, y, e.name, kText, /*upward=*/false, g.scale);
    y += g.row();
  }
}

// Finite points of a series in pixels, in the order given.
std::vector<Point> series_pixels(const Series& s, const PanelLayout& L) {
  std::vector<Point> p;
  const size_t n = std::min(s.x.size(), s.y.size());
  for (size_t i = 0; i < n; ++i)
    if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
      p.push_back({L.x.to_pixel(s.x[i]), L.y.to_pixel(s.y[i])});
  return p;
}

// The front's points in pixels, sorted by x, and its staircase: from each point across to the
// next one's x, then down (or up) to it, the boundary of the region the front dominates.
std::vector<Point> front_pixels(const Panel& panel, const PanelLayout& L) {
  std::vector<std::pair<double, double>> f;
  for (const auto& [x, y] : panel.front)
    if (std::isfinite(x) && std::isfinite(y)) f.push_back({x, y});
  std::sort(f.begin(), f.end());
  std::vector<Point> p;
  for (const auto& [x, y] : f) p.push_back({L.x.to_pixel(x), L.y.to_pixel(y)});
  return p;
}

std::vector<Point> staircase(const std::vector<Point>& p) {
  std::vector<Point> s;
  for (size_t i = 0; i < p.size(); ++i) {
    if (i > 0) s.push_back({p[i].x, p[i - 1].y});
    s.push_back(p[i]);
  }
  return s;
}

// Points every few pixels along a polyline, for the legend's placement.
void sample_polyline(const std::vector<Point>& p, std::vector<Point>& out) {
  for (size_t i = 0; i + 1 < p.size(); ++i) {
    const double len = std::hypot(p[i + 1].x - p[i].x, p[i + 1].y - p[i].y);
    const int n = clamp_to_int(len / 4, 1, 4096);
    for (int k = 0; k < n; ++k) {
      const double t = static_cast<double>(k) / n;
      out.push_back({p[i].x + t * (p[i + 1].x - p[i].x), p[i].y + t * (p[i + 1].y - p[i].y)});
    }
  }
}

void draw_ticks(Canvas& canvas, const PanelLayout& L) {
  // x ticks below the plot area, labels centred under them, a label skipped where it would
  // touch the one before.
  int last_right = std::numeric_limits<int>::min();
  for (const Tick& t : axis_ticks(L.x)) {
    const int px = clamp_to_int(std::floor(L.x.to_pixel(t.value)), -1, L.right + 1);
    const int len = t.label.empty() ? kMinorTick : kMajorTick;
    canvas.fill_rect(px, L.bottom + 1, px + 1, L.bottom + 1 + len, kFrame);
    if (t.label.empty()) continue;
    const int w = text_width(t.label), x0 = px - w / 2;
    if (x0 < last_right + 8) continue;
    draw_text(canvas, x0, L.bottom + 1 + kMajorTick + kLabelGap, t.label, kText);
    last_right = x0 + w;
  }
  // y ticks left of the plot area, labels right-aligned and centred on them, from the bottom up.
  int last_top = std::numeric_limits<int>::max();
  for (const Tick& t : axis_ticks(L.y)) {
    const int py = clamp_to_int(std::floor(L.y.to_pixel(t.value)), -1, L.bottom + 1);
    const int len = t.label.empty() ? kMinorTick : kMajorTick;
    canvas.fill_rect(L.left - len, py, L.left, py + 1, kFrame);
    if (t.label.empty()) continue;
    const int y0 = py - kCapHeight / 2;
    if (y0 + kCapHeight > last_top - 6) continue;
    draw_text(canvas, L.left - kMajorTick - kLabelGap - text_width(t.label), y0, t.label, kText);
    last_top = y0;
  }
}

// Grid lines run across the plot area at labelled ticks, and at every decade of a log axis.
bool has_grid_line(const Axis& a, const Tick& t) {
  if (!t.label.empty()) return true;
  const double decade = std::log10(t.value);
  return a.log && std::abs(decade - std::round(decade)) < 1e-9;
}

void draw_grid(Canvas& canvas, const PanelLayout& L) {
  for (const Tick& t : axis_ticks(L.x)) {
    if (!has_grid_line(L.x, t)) continue;
    const int px = clamp_to_int(std::floor(L.x.to_pixel(t.value)), -1, L.right + 1);
    canvas.fill_rect(px, L.top + 1, px + 1, L.bottom, kGrid);
  }
  for (const Tick& t : axis_ticks(L.y)) {
    if (!has_grid_line(L.y, t)) continue;
    const int py = clamp_to_int(std::floor(L.y.to_pixel(t.value)), -1, L.bottom + 1);
    canvas.fill_rect(L.left + 1, py, L.right, py + 1, kGrid);
  }
}

void draw_frame(Canvas& canvas, const PanelLayout& L) {
  canvas.fill_rect(L.left, L.top, L.right + 1, L.top + 1, kFrame);
  canvas.fill_rect(L.left, L.bottom, L.right + 1, L.bottom + 1, kFrame);
  canvas.fill_rect(L.left, L.top, L.left + 1, L.bottom + 1, kFrame);
  canvas.fill_rect(L.right, L.top, L.right + 1, L.bottom + 1, kFrame);
}

// Draws one panel into `canvas`, whose clip rectangle is the panel, with top-left corner (ox, oy).
void draw_panel(Canvas& canvas, int ox, int oy, int width, int height, const Panel& panel,
                const std::vector<size_t>& slots) {
  PanelLayout L = panel_layout(panel, width, height);
  // Everything below is drawn in chart coordinates: shift the layout to the panel's corner.
  L.left += ox, L.right += ox, L.top += oy, L.bottom += oy;
  L.x.pixel_lo += ox, L.x.pixel_hi += ox, L.y.pixel_lo += oy, L.y.pixel_hi += oy;

  Canvas inside = canvas.clipped(L.left + 1, L.top + 1, L.right, L.bottom);
  // Markers on the frame stay whole; beyond it they would run into the tick labels.
  const int m = static_cast<int>(std::ceil(kRingRadius + kRingWidth));
  Canvas markers = canvas.clipped(L.left - m, L.top - m, L.right + 1 + m, L.bottom + 1 + m);

  draw_grid(canvas, L);

  std::vector<std::vector<Point>> points;
  std::vector<Point> marks;  // what the legend should not cover
  for (const Series& s : panel.series) {
    points.push_back(series_pixels(s, L));
    marks.insert(marks.end(), points.back().begin(), points.back().end());
  }
  for (size_t i = 0; i < panel.series.size(); ++i) {
    if (!panel.series[i].connect) continue;
    std::vector<Point> line = points[i];
    std::stable_sort(line.begin(), line.end(), [](Point a, Point b) { return a.x < b.x; });
    draw_polyline(inside, line, kLineWidth, colour_of(slots[i]));
    sample_polyline(line, marks);
  }
  const std::vector<Point> front = front_pixels(panel, L);
  const std::vector<Point> stairs = staircase(front);
  draw_polyline(inside, stairs, kFrontWidth, kBlack);
  sample_polyline(stairs, marks);
  marks.insert(marks.end(), front.begin(), front.end());

  draw_frame(canvas, L);
  draw_ticks(canvas, L);

  for (size_t i = 0; i < panel.series.size(); ++i)
    for (Point p : points[i]) draw_marker(markers, p, marker_of(slots[i]), colour_of(slots[i]));
  for (Point p : front) draw_ring(markers, p, kRingRadius, kRingWidth, kBlack);

  if (marks.empty())
    draw_text_centred(inside, (L.left + L.right + 1) / 2.0, (L.top + L.bottom - kCapHeight) / 2,
                      "no data", kNoData);

  std::vector<LegendEntry> entries;
  for (size_t i = 0; i < panel.series.size(); ++i) {
    const Series& s = panel.series[i];
    const bool listed = std::any_of(entries.begin(), entries.end(),
                                    [&](const LegendEntry& e) { return e.name == s.name; });
    if (s.name.empty() || listed) continue;
    entries.push_back({s.name, colour_of(slots[i]), marker_of(slots[i]), s.connect, false});
  }
  if (!front.empty()) entries.push_back({"Pareto front", kBlack, Marker::kDisc, true, true});
  if (!entries.empty()) {
    draw_legend(inside, place_legend(entries, L, marks), entries);
  }

  // Axis labels and title, centred on the plot area.
  const double cx = (L.left + L.right + 1) / 2.0;
  draw_text_centred(canvas, cx, oy + height - kPad - kLineHeight, panel.x_label, kText);
  const int label_height = text_width(panel.y_label);
  draw_text(canvas, ox + kPad, (L.top + L.bottom + 1 - label_height) / 2, panel.y_label, kText,
            /*upward=*/true);
  draw_text_centred(canvas, cx, oy + kPad, panel.title, kText);
}

}  // namespace

double Axis::to_pixel(double v) const {
  double t;
  if (log) {
    const double a = std::log10(lo), b = std::log10(hi);
    t = v > 0 ? (std::log10(v) - a) / (b - a) : 0.0;
  } else {
    t = (v - lo) / (hi - lo);
  }
  t = std::isnan(t) ? 0.0 : std::clamp(t, 0.0, 1.0);
  return pixel_lo + t * (pixel_hi - pixel_lo);
}

std::vector<Tick> axis_ticks(const Axis& axis) {
  return axis.log ? log_ticks(axis) : linear_ticks(axis);
}

PanelLayout panel_layout(const Panel& panel, int width, int height) {
  PanelLayout L;
  const bool floor = panel.log_y && panel.y_floor > 0;
  L.x = make_axis(panel_values(panel, true), panel.log_x, 0.0);
  L.y = make_axis(panel_values(panel, false), panel.log_y, floor ? panel.y_floor : 0.0);
  const std::vector<Tick> xt = axis_ticks(L.x), yt = axis_ticks(L.y);

  // From the edges inwards: padding, the title or half a tick label (the top y label is centred
  // on the frame), padding; on the left the upward y label, the tick labels and the ticks; below,
  // the ticks, their labels and the x label; on the right room for half the last x tick label.
  L.top = kPad + std::max(panel.title.empty() ? 0 : kCapHeight + kPad, kCapHeight / 2);
  L.left = kPad + (panel.y_label.empty() ? 0 : kLineHeight + kPad) + widest_label(yt) + kLabelGap +
           kMajorTick;
  const int below =
      kMajorTick + kLabelGap + kCapHeight + kPad + (panel.x_label.empty() ? 0 : kLineHeight + kPad);
  L.bottom = height - 1 - below;
  int last_label = 0;
  for (const Tick& t : xt)
    if (!t.label.empty()) last_label = text_width(t.label);
  L.right = width - 1 - std::max(2 * kPad, last_label / 2 + 2);
  // A panel too small for its margins still gets a plot area of at least one pixel inside.
  L.right = std::max(L.right, L.left + 2);
  L.bottom = std::max(L.bottom, L.top + 2);

  L.x.pixel_lo = L.left + 0.5, L.x.pixel_hi = L.right + 0.5;
  L.y.pixel_lo = L.bottom + 0.5, L.y.pixel_hi = L.top + 0.5;
  return L;
}

std::vector<std::vector<Rgb>> series_colours(const std::vector<Panel>& panels) {
  std::vector<std::vector<Rgb>> colours;
  for (const std::vector<size_t>& slots : colour_slots(panels)) {
    colours.emplace_back();
    for (size_t s : slots) colours.back().push_back(colour_of(s));
  }
  return colours;
}

Image render_chart(const std::vector<Panel>& panels_in, int columns, int panel_width,
                   int panel_height) {
  if (columns <= 0 || panel_width <= 0 || panel_height <= 0)
    throw Error("render_chart: columns = " + std::to_string(columns) + ", panel size " +
                std::to_string(panel_width) + " x " + std::to_string(panel_height) +
                ": all must be > 0");
  for (size_t p = 0; p < panels_in.size(); ++p)
    for (size_t s = 0; s < panels_in[p].series.size(); ++s) {
      const Series& series = panels_in[p].series[s];
      if (series.x.size() != series.y.size())
        throw Error("render_chart: panels[" + std::to_string(p) + "].series[" + std::to_string(s) +
                    "] \"" + series.name + "\": x has " + std::to_string(series.x.size()) +
                    " values and y " + std::to_string(series.y.size()) + ": must be as many");
    }
  const std::vector<Panel> one_empty(1);
  const std::vector<Panel>& panels = panels_in.empty() ? one_empty : panels_in;
  const long n = static_cast<long>(panels.size());
  const long cols = std::min<long>(columns, n), rows = (n + cols - 1) / cols;
  const long w = cols * panel_width, h = rows * panel_height;
  if (w > kMaxPixels || h > kMaxPixels || w * h > kMaxPixels)
    throw Error("render_chart: " + std::to_string(w) + " x " + std::to_string(h) +
                " pixels: must be at most " + std::to_string(kMaxPixels) + " in all");

  Image image(static_cast<int>(w), static_cast<int>(h));
  std::fill(image.rgba.begin(), image.rgba.end(), uint8_t{255});
  const std::vector<std::vector<size_t>> slots = colour_slots(panels);
  for (long k = 0; k < n; ++k) {
    const int ox = static_cast<int>((k % cols) * panel_width);
    const int oy = static_cast<int>((k / cols) * panel_height);
    Canvas canvas(image, ox, oy, ox + panel_width, oy + panel_height);
    draw_panel(canvas, ox, oy, panel_width, panel_height, panels[k], slots[k]);
  }
  return image;
}

std::vector<size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    throw Error("pareto_front: x has " + std::to_string(x.size()) + " values and y " +
                std::to_string(y.size()) + ": must be as many");
  std::vector<size_t> order;
  for (size_t i = 0; i < x.size(); ++i)
    if (!std::isnan(x[i]) && !std::isnan(y[i])) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]);
  });
  // Sweep by increasing x, one group of equal x at a time. Within a group only the points of
  // least y can be on the front (the others are beaten by them: equal x, smaller y); they are,
  // unless a point of smaller x has y <= theirs.
  std::vector<size_t> front;
  double best_y = kInf;  // least y over all smaller x
  bool any_before = false;
  for (size_t g = 0; g < order.size();) {
    size_t end = g;
    while (end < order.size() && x[order[end]] == x[order[g]]) ++end;
    const double group_y = y[order[g]];
    if (!any_before || group_y < best_y)
      for (size_t k = g; k < end && y[order[k]] == group_y; ++k) front.push_back(order[k]);
    best_y = any_before ? std::min(best_y, group_y) : group_y;
    any_before = true;
    g = end;
  }
  return front;
}

}  // namespace raywarp::plot
