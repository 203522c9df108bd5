#include "studies/chart.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "base/error.h"
#include "library/image.h"

namespace raywarp::chart {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Log10 of data is clamped to +-kMaxDecade, so that 10^(an axis end) stays a normal double.
constexpr double kMaxDecade = 300;

// matplotlib's "tab10": ten colours told apart on white, and by most colour-blind readers in
// pairs of neighbours.
constexpr std::array<const char*, 10> kPalette{"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                               "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                               "#bcbd22", "#17becf"};

// Layout, in user units. Text widths are estimated (the viewer picks the font): kCharWidth is a
// generous mean advance of a sans-serif character at kFontSize.
constexpr double kFontSize = 12, kCharWidth = 7;
constexpr double kTitleHeight = 30, kLegendRow = 20, kMargin = 10;
// The plot area inside a panel's cell: room for the title above, the y tick labels and the y
// label to the left, the x tick labels and the x label below.
constexpr double kLeft = 66, kRight = 16, kTop = 26, kBottom = 44;
constexpr double kPointRadius = 3.5, kFrontRadius = 5.5;

// A coordinate: one decimal is a tenth of a pixel.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

// A data value, for tooltips.
std::string value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

double text_width(const std::string& s) {
  // Characters, not bytes: UTF-8 continuation bytes do not count.
  return kCharWidth * static_cast<double>(std::count_if(
                          s.begin(), s.end(), [](char c) { return (uint8_t(c) & 0xC0) != 0x80; }));
}

// A log axis: [a, b] in log10 of the data mapped linearly onto pixels [p0, p1].
struct Axis {
  double a = 0, b = 1, p0 = 0, p1 = 1;
  double at_log(double lg) const { return p0 + (std::clamp(lg, a, b) - a) / (b - a) * (p1 - p0); }
  double at(double v) const { return at_log(std::log10(v)); }
};

// The log10 range for data spanning [lo, hi] in log10 (lo > hi: no data): padded by 4 % of its
// span and rounded out to half decades, so that no point sits on the frame; a single value gets
// a decade around it; no data gets [1, 10]. floor > 0 is the lower end.
std::pair<double, double> log_range(double lo, double hi, double floor) {
  if (floor > 0) {
    const double a = std::clamp(std::log10(floor), -kMaxDecade, kMaxDecade - 1);
    const double top = lo <= hi ? std::max(hi, a) : a;
    if (top - a < 1e-9) return {a, a + 1};
    return {a, std::min(std::ceil(2 * (top + 0.04 * (top - a))) / 2, kMaxDecade)};
  }
  if (!(lo <= hi)) return {0, 1};
  const double pad = hi - lo < 1e-9 ? 0.5 : 0.04 * (hi - lo);
  return {std::max(std::floor(2 * (lo - pad)) / 2, -kMaxDecade),
          std::min(std::ceil(2 * (hi + pad)) / 2, kMaxDecade)};
}

// The label of m * 10^k, m in 1..9: "0.05", "1", "200", or "1e-3", "5e4" beyond that.
std::string tick_label(int m, int k) {
  char buf[32];
  if (k >= -2 && k <= 3)
    std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -k), m * std::pow(10.0, k));
  else
    std::snprintf(buf, sizeof buf, "%de%d", m, k);
  return buf;
}

struct Tick {
  double lg = 0;      // log10 of the value
  std::string label;  // empty: unlabelled
  bool decade = false;
};

// Every decade in [a, b], labelled (every stride-th of them beyond eight), and minor ticks at 2..9
// times a decade while there are at most eight decades. Under two decades (a range is at least
// one, so this still labels two or more), 2 and 5 times a decade are labelled too.
std::vector<Tick> log_ticks(double a, double b) {
  const int k0 = static_cast<int>(std::ceil(a - 1e-9)), k1 = static_cast<int>(std::floor(b + 1e-9));
  const int decades = k1 - k0 + 1;
  const int stride = (decades + 7) / 8;
  auto inside = [&](double lg) { return lg >= a - 1e-9 && lg <= b + 1e-9; };
  std::vector<Tick> ticks;
  for (int k = k0 - 1; k <= k1; ++k)
    for (int m = 1; m <= 9; ++m) {
      const double lg = k + std::log10(m);
      if (!inside(lg) || (m > 1 && decades > 8)) continue;
      const bool labelled = m == 1 ? k % stride == 0 : decades < 2 && (m == 2 || m == 5);
      ticks.push_back({lg, labelled ? tick_label(m, k) : "", m == 1});
    }
  return ticks;
}

struct Mark {
  double x = 0, y = 0;  // as drawn (y raised to the floor)
  double raw_y = 0;     // as given
};

// What a panel shows of its data, and how many points it leaves out.
struct Shown {
  std::vector<std::vector<Mark>> series;  // [series][point]
  std::vector<Mark> front;                // sorted by x
  long not_finite = 0, not_positive = 0;
  double x_lo = kInf, x_hi = -kInf, y_lo = kInf, y_hi = -kInf;  // log10 extents
};

Shown shown_data(const Panel& panel) {
  Shown s;
  auto keep = [&](double x, double y, std::vector<Mark>& out) {
    if (!std::isfinite(x) || !std::isfinite(y)) return void(++s.not_finite);
    const double drawn_y = panel.y_floor > 0 ? std::max(y, panel.y_floor) : y;
    if (x <= 0 || drawn_y <= 0) return void(++s.not_positive);
    out.push_back({x, drawn_y, y});
    const double lx = std::clamp(std::log10(x), -kMaxDecade, kMaxDecade);
    const double ly = std::clamp(std::log10(drawn_y), -kMaxDecade, kMaxDecade);
    s.x_lo = std::min(s.x_lo, lx), s.x_hi = std::max(s.x_hi, lx);
    s.y_lo = std::min(s.y_lo, ly), s.y_hi = std::max(s.y_hi, ly);
  };
  for (const Series& series : panel.series) {
    s.series.emplace_back();
    for (size_t i = 0; i < series.x.size(); ++i) keep(series.x[i], series.y[i], s.series.back());
  }
  for (const auto& [x, y] : panel.front) keep(x, y, s.front);
  std::stable_sort(s.front.begin(), s.front.end(),
                   [](const Mark& p, const Mark& q) { return p.x < q.x; });
  return s;
}

// The parts joined: SVG is assembled by appending, never by a literal + a temporary string
// (which GCC 12 misreads under -Wrestrict).
std::string cat(std::initializer_list<std::string_view> parts) {
  std::string out;
  for (std::string_view p : parts) out.append(p);
  return out;
}

// A text element, its content escaped.
void text(std::string& svg, const std::string& attributes, const std::string& content) {
  svg += cat({"<text ", attributes, ">", xml_escape(content), "</text>\n"});
}

void draw_panel(std::string& svg, const Panel& panel, const std::vector<std::string>& colours,
                double x0, double y0, double width, double height) {
  const double left = x0 + kLeft, right = x0 + width - kRight;
  const double top = y0 + kTop, bottom = y0 + height - kBottom;
  const Shown s = shown_data(panel);
  Axis x, y;
  std::tie(x.a, x.b) = log_range(s.x_lo, s.x_hi, 0);
  std::tie(y.a, y.b) = log_range(s.y_lo, s.y_hi, panel.y_floor);
  x.p0 = left, x.p1 = right, y.p0 = bottom, y.p1 = top;
  const std::string l = num(left), r = num(right), t = num(top), b = num(bottom);
  const std::string mid_x = num((left + right) / 2);

  svg += "<g class=\"panel\">\n";
  text(svg,
       cat({"class=\"panel-title\" x=\"", mid_x, "\" y=\"", num(y0 + 18),
            "\" text-anchor=\"middle\" font-weight=\"bold\""}),
       panel.title);

  // Grid lines at the labelled ticks, tick marks (longer on decades), labels.
  std::string grid, marks;
  for (const Tick& tick : log_ticks(x.a, x.b)) {
    const std::string px = num(x.at_log(tick.lg));
    if (!tick.label.empty()) {
      grid += cat({"M", px, " ", t, "V", b});
      text(svg,
           cat({"class=\"x-tick\" x=\"", px, "\" y=\"", num(bottom + 16),
                "\" text-anchor=\"middle\""}),
           tick.label);
    }
    marks += cat({"M", px, " ", b, tick.decade ? "v6" : "v3"});
  }
  for (const Tick& tick : log_ticks(y.a, y.b)) {
    const std::string py = num(y.at_log(tick.lg));
    if (!tick.label.empty()) {
      grid += cat({"M", l, " ", py, "H", r});
      text(svg,
           cat({"class=\"y-tick\" x=\"", num(left - 8), "\" y=\"", py,
                "\" dy=\"0.35em\" text-anchor=\"end\""}),
           tick.label);
    }
    marks += cat({"M", l, " ", py, tick.decade ? "h-6" : "h-3"});
  }
  if (!grid.empty()) svg += cat({"<path class=\"grid\" d=\"", grid, "\" stroke=\"#e4e4e4\"/>\n"});
  if (!marks.empty()) svg += cat({"<path class=\"ticks\" d=\"", marks, "\" stroke=\"black\"/>\n"});
  svg += cat({"<rect class=\"frame\" x=\"", l, "\" y=\"", t, "\" width=\"", num(right - left),
              "\" height=\"", num(bottom - top), "\" fill=\"none\" stroke=\"black\"/>\n"});
  text(svg,
       cat({"class=\"x-label\" x=\"", mid_x, "\" y=\"", num(bottom + 34),
            "\" text-anchor=\"middle\""}),
       panel.x_label);
  const std::string lx = num(x0 + 16), ly = num((top + bottom) / 2);
  text(svg,
       cat({"class=\"y-label\" x=\"", lx, "\" y=\"", ly, "\" transform=\"rotate(-90 ", lx, " ", ly,
            ")\" text-anchor=\"middle\""}),
       panel.y_label);

  // The front's staircase under the points, its hollow circles over them.
  if (!s.front.empty()) {
    std::string points = cat({num(x.at(s.front[0].x)), ",", num(y.at(s.front[0].y))});
    for (size_t i = 1; i < s.front.size(); ++i) {
      const std::string px = num(x.at(s.front[i].x));
      points +=
          cat({" ", px, ",", num(y.at(s.front[i - 1].y)), " ", px, ",", num(y.at(s.front[i].y))});
    }
    svg += cat({"<polyline class=\"front\" points=\"", points,
                "\" fill=\"none\" stroke=\"black\" stroke-width=\"1.8\"/>\n"});
  }
  for (size_t k = 0; k < s.series.size(); ++k) {
    if (s.series[k].empty()) continue;
    const std::string& name = panel.series[k].name;
    svg += cat(
        {"<g class=\"series\" fill=\"", colours[k], "\" stroke=\"white\" stroke-width=\"0.5\">\n"});
    for (const Mark& m : s.series[k])
      svg +=
          cat({"<circle class=\"point\" cx=\"", num(x.at(m.x)), "\" cy=\"", num(y.at(m.y)),
               "\" r=\"", num(kPointRadius), "\"><title>",
               xml_escape(cat({name, name.empty() ? "" : ": ", value(m.x), ", ", value(m.raw_y)})),
               "</title></circle>\n"});
    svg += "</g>\n";
  }
  for (const Mark& m : s.front)
    svg += cat({"<circle class=\"front-point\" cx=\"", num(x.at(m.x)), "\" cy=\"", num(y.at(m.y)),
                "\" r=\"", num(kFrontRadius),
                "\" fill=\"none\" stroke=\"black\" stroke-width=\"1.5\"/>\n"});

  bool any = !s.front.empty();
  for (const auto& drawn : s.series) any = any || !drawn.empty();
  std::string note;
  if (const long out = s.not_finite + s.not_positive; out > 0) {
    note = cat({std::to_string(out), out > 1 ? " points" : " point", " left out:"});
    if (s.not_finite) note += cat({" ", std::to_string(s.not_finite), " not finite"});
    if (s.not_finite && s.not_positive) note += ",";
    if (s.not_positive) note += cat({" ", std::to_string(s.not_positive), " not > 0 (log scale)"});
  }
  if (!any) note = note.empty() ? "no data" : cat({"no data (", note, ")"});
  if (!note.empty())
    text(svg,
         cat({"class=\"note\" x=\"", num(left + 6), "\" y=\"", num(top + 15),
              "\" font-size=\"11\" fill=\"#b00000\""}),
         note);
  svg += "</g>\n";
}

}  // namespace

std::string xml_escape(const std::string& s) {
  static const char kReplacement[] = "\xEF\xBF\xBD";  // U+FFFD
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<uint8_t>(s[i]);
    if (c < 0x80) {
      switch (c) {
        case '&':
          out += "&amp;";
          break;
        case '<':
          out += "&lt;";
          break;
        case '>':
          out += "&gt;";
          break;
        case '"':
          out += "&quot;";
          break;
        case '\'':
          out += "&apos;";
          break;
        default:
          out += c < 0x20 && c != '\t' && c != '\n' && c != '\r' ? kReplacement : s.substr(i, 1);
      }
      ++i;
      continue;
    }
    // A UTF-8 sequence: its lead byte gives the length; no overlong forms, surrogates, or code
    // points beyond U+10FFFF, and not U+FFFE or U+FFFF, which XML forbids.
    const int n = c >= 0xC2 && c <= 0xDF   ? 2
                  : c >= 0xE0 && c <= 0xEF ? 3
                  : c >= 0xF0 && c <= 0xF4 ? 4
                                           : 0;
    uint32_t cp = c & (n == 2 ? 0x1Fu : n == 3 ? 0x0Fu : 0x07u);
    bool ok = n > 0 && i + n <= s.size();
    for (int k = 1; ok && k < n; ++k) {
      const auto d = static_cast<uint8_t>(s[i + k]);
      ok = (d & 0xC0) == 0x80;
      cp = cp << 6 | (d & 0x3Fu);
    }
    ok = ok && !(n == 3 && cp < 0x800) && !(n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) &&
         !(cp >= 0xD800 && cp <= 0xDFFF) && cp != 0xFFFE && cp != 0xFFFF;
    if (ok) {
      out.append(s, i, static_cast<size_t>(n));
      i += static_cast<size_t>(n);
    } else {
      out += kReplacement;
      ++i;
    }
  }
  return out;
}

std::string to_svg(const Chart& chart) {
  if (chart.columns < 1)
    throw Error("chart: columns " + std::to_string(chart.columns) + ": must be at least 1");
  for (int size : {chart.panel_width, chart.panel_height})
    if (size < 100 || size > 10000)
      throw Error("chart: panel size " + std::to_string(chart.panel_width) + "x" +
                  std::to_string(chart.panel_height) + ": each side must be in [100, 10000]");
  for (const Panel& panel : chart.panels) {
    if (!(panel.y_floor >= 0 && std::isfinite(panel.y_floor)))
      throw Error("chart: panel '" + panel.title + "': y_floor " + value(panel.y_floor) +
                  ": must be finite and >= 0");
    for (const Series& s : panel.series)
      if (s.x.size() != s.y.size())
        throw Error("chart: series '" + s.name + "' of panel '" + panel.title + "' has " +
                    std::to_string(s.x.size()) + " x values and " + std::to_string(s.y.size()) +
                    " y values: must be as many");
  }

  // Colours by name over all panels; the legend in that order.
  std::map<std::string, size_t> slot_of;
  std::vector<std::string> legend;
  std::vector<std::vector<std::string>> colours;
  size_t slots = 0;
  bool any_front = false;
  for (const Panel& panel : chart.panels) {
    colours.emplace_back();
    any_front = any_front || !panel.front.empty();
    for (const Series& s : panel.series) {
      size_t slot = slots;
      if (s.name.empty()) {
        ++slots;
      } else if (auto [it, inserted] = slot_of.emplace(s.name, slots); inserted) {
        ++slots;
        legend.push_back(s.name);
      } else {
        slot = it->second;
      }
      colours.back().push_back(kPalette[slot % kPalette.size()]);
    }
  }

  const size_t n = chart.panels.size();
  const size_t columns =
      std::min<size_t>(static_cast<size_t>(chart.columns), std::max<size_t>(n, 1));
  const size_t rows = (std::max<size_t>(n, 1) + columns - 1) / columns;
  const double width = static_cast<double>(columns) * chart.panel_width;

  // The legend's entries, laid out in rows that wrap at the chart's width.
  struct Entry {
    std::string name, colour;
    double x = 0;
    int row = 0;
  };
  std::vector<Entry> entries;
  for (const std::string& name : legend)
    entries.push_back({name, kPalette[slot_of[name] % kPalette.size()]});
  if (any_front) entries.push_back({"Pareto front", ""});
  double cursor = kMargin;
  int row = 0;
  for (Entry& e : entries) {
    const double w = 22 + text_width(e.name) + 16;
    if (cursor > kMargin && cursor + w > width - kMargin) cursor = kMargin, ++row;
    e.x = cursor, e.row = row;
    cursor += w;
  }
  const double title_height = chart.title.empty() ? 0 : kTitleHeight;
  const double legend_top = title_height + (entries.empty() ? 0 : 4);
  const double header = legend_top + (entries.empty() ? 0 : (row + 1) * kLegendRow);
  const double height =
      header + (n == 0 ? 2 * kLegendRow : static_cast<double>(rows) * chart.panel_height);

  const std::string w = num(width), h = num(height);
  std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg += cat({"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"", w, "\" height=\"", h,
              "\" viewBox=\"0 0 ", w, " ", h,
              "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\" font-size=\"",
              num(kFontSize), "\">\n"});
  svg += cat({"<rect width=\"", w, "\" height=\"", h, "\" fill=\"white\"/>\n"});
  if (!chart.title.empty())
    text(svg,
         cat({"class=\"title\" x=\"", num(width / 2),
              "\" y=\"21\" text-anchor=\"middle\" font-size=\"16\" font-weight=\"bold\""}),
         chart.title);
  if (!entries.empty()) {
    svg += "<g class=\"legend\">\n";
    for (const Entry& e : entries) {
      const std::string cx = num(e.x + 8), cy = num(legend_top + (e.row + 0.5) * kLegendRow);
      if (e.colour.empty())  // the front: a line through a hollow circle
        svg += cat({"<path d=\"M", num(e.x), " ", cy,
                    "h16\" stroke=\"black\" stroke-width=\"1.8\"/><circle cx=\"", cx, "\" cy=\"",
                    cy, "\" r=\"", num(kFrontRadius),
                    "\" fill=\"white\" stroke=\"black\" stroke-width=\"1.5\"/>\n"});
      else
        svg +=
            cat({"<circle cx=\"", cx, "\" cy=\"", cy, "\" r=\"4.5\" fill=\"", e.colour, "\"/>\n"});
      text(svg, cat({"x=\"", num(e.x + 22), "\" y=\"", cy, "\" dy=\"0.35em\""}), e.name);
    }
    svg += "</g>\n";
  }
  if (n == 0)
    text(svg, cat({"class=\"note\" x=\"", num(kMargin), "\" y=\"", num(header + 24), "\""}),
         "no data");
  for (size_t k = 0; k < n; ++k)
    draw_panel(svg, chart.panels[k], colours[k],
               static_cast<double>(k % columns) * chart.panel_width,
               header + static_cast<double>(k / columns) * chart.panel_height, chart.panel_width,
               chart.panel_height);
  svg += "</svg>\n";
  return svg;
}

void write_svg(const std::string& path, const Chart& chart) {
  const std::string svg = to_svg(chart);
  write_file_atomic(path, svg.data(), svg.size());
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

}  // namespace raywarp::chart
