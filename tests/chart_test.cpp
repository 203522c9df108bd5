// The SVG chart: Pareto fronts against a brute-force search; the document read by a real XML
// parser (xmllint, else python3's xml.etree); points read back from their circles and mapped
// back through the log scales the tick labels state; the front's subset; what is left out and
// the note saying so; decade ticks; empty input; escaping; colours by name; bad arguments.
#include "studies/chart.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"

namespace raywarp::chart {
namespace {

namespace fs = std::filesystem;

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

TEST(ParetoFront, HandMadeSets) {
  // (3, 4) is beaten by (2, 3); (5, 1) by (4, 1), equal in y and worse in x.
  EXPECT_EQ(pareto_front({1, 2, 3, 4, 5}, {5, 3, 4, 1, 1}), (Indices{0, 1, 3}));
  EXPECT_EQ(pareto_front({1, 1}, {2, 3}), (Indices{0}));
  EXPECT_EQ(pareto_front({3, 2}, {1, 1}), (Indices{1}));
  EXPECT_EQ(pareto_front({2, 1, 1, 3}, {2, 4, 4, 1}), (Indices{1, 2, 0, 3}));  // duplicates
  EXPECT_EQ(pareto_front({30, 10, 20}, {1, 3, 2}), (Indices{1, 2, 0}));        // sorted by x
  // Each NaN point would beat every other point if its NaN were read as small.
  EXPECT_EQ(pareto_front({kNaN, 0, 2, 3}, {0, kNaN, 2, 1}), (Indices{2, 3}));
  EXPECT_EQ(pareto_front({kInf, 1, -kInf}, {-kInf, 1, 5}), (Indices{2, 1, 0}));
  EXPECT_EQ(pareto_front({}, {}), Indices{});
  EXPECT_THROW(pareto_front({1, 2}, {1}), Error);
}

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

// ---- An XML parser that is not ours ----

struct Run {
  int code = -1;
  std::string output;
};

Run run(const std::string& command) {
  Run r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool have(const std::string& tool) { return run("command -v " + tool).code == 0; }

enum class Parser { kNone, kXmllint, kPython };

Parser parser() {
  static const Parser p =
      have("xmllint") ? Parser::kXmllint
      : have("python3") && run("python3 -c 'import xml.etree.ElementTree'").code == 0
          ? Parser::kPython
          : Parser::kNone;
  return p;
}

#define REQUIRE_PARSER()                                                                  \
  if (parser() == Parser::kNone)                                                          \
  GTEST_SKIP() << "no XML parser to check the SVG with: install xmllint (Debian package " \
                  "libxml2-utils) or python3"

// A file per test, removed at the end of the test.
class TempFile {
 public:
  explicit TempFile(const std::string& text) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / (std::string("raywarp_chart_test_") + info->name() + "_" +
                                         std::to_string(std::random_device{}()) + ".svg");
    std::ofstream(path_, std::ios::binary) << text;
  }
  ~TempFile() { fs::remove(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// The parser's verdict on `svg`: empty if well-formed, else its message.
std::string xml_errors(const std::string& svg) {
  const TempFile file(svg);
  const std::string path = "'" + file.path().string() + "'";
  const Run r =
      parser() == Parser::kXmllint
          ? run("xmllint --noout " + path)
          : run("python3 -c 'import sys, xml.etree.ElementTree as E; E.parse(sys.argv[1])' " +
                path);
  return r.code == 0 ? "" : "parser exit " + std::to_string(r.code) + ": " + r.output;
}

// The string value, as the parser reads it, of the first element whose class is `cls`.
std::string parsed_text(const std::string& svg, const std::string& cls) {
  const TempFile file(svg);
  const std::string path = "'" + file.path().string() + "'";
  const Run r = parser() == Parser::kXmllint
                    ? run("xmllint --xpath \"string((//*[@class='" + cls + "'])[1])\" " + path)
                    : run("python3 -c 'import sys, xml.etree.ElementTree as E\n"
                          "for e in E.parse(sys.argv[1]).iter():\n"
                          "  if e.get(\"class\") == sys.argv[2]:\n"
                          "    sys.stdout.write(\"\".join(e.itertext())); break' " +
                          path + " " + cls);
  EXPECT_EQ(r.code, 0) << r.output;
  std::string out = r.output;
  if (parser() == Parser::kXmllint && !out.empty() && out.back() == '\n')
    out.pop_back();  // its own
  return out;
}

// ---- Reading a chart back ----

// The text of each panel's group, in order.
std::vector<std::string> panels_of(const std::string& svg) {
  std::vector<std::string> panels;
  const std::string open = "<g class=\"panel\">";
  for (size_t at = svg.find(open); at != std::string::npos;) {
    const size_t next = svg.find(open, at + open.size());
    panels.push_back(svg.substr(at, next == std::string::npos ? std::string::npos : next - at));
    at = next;
  }
  return panels;
}

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

struct Xy {
  double x = 0, y = 0;
};

// The centres of the circles of class `cls`, in order.
std::vector<Xy> circles(const std::string& panel, const std::string& cls) {
  const std::regex re("<circle class=\"" + cls + "\" cx=\"([-0-9.]+)\" cy=\"([-0-9.]+)\"");
  std::vector<Xy> out;
  for (std::sregex_iterator it(panel.begin(), panel.end(), re), end; it != end; ++it)
    out.push_back({std::stod((*it)[1]), std::stod((*it)[2])});
  return out;
}

struct LabelledTick {
  double pixel = 0;  // x of an x tick, y of a y tick
  std::string label;
};

std::vector<LabelledTick> ticks(const std::string& panel, char axis) {
  const std::regex re(axis == 'x' ? "<text class=\"x-tick\" x=\"([-0-9.]+)\"[^>]*>([^<]*)</text>"
                                  : "<text class=\"y-tick\" x=\"[-0-9.]+\" y=\"([-0-9.]+)\"[^>]*>"
                                    "([^<]*)</text>");
  std::vector<LabelledTick> out;
  for (std::sregex_iterator it(panel.begin(), panel.end(), re), end; it != end; ++it)
    out.push_back({std::stod((*it)[1]), (*it)[2]});
  return out;
}

// The log scale an axis's labelled ticks state: log10(value) = a + b * pixel, from its first and
// last label; every label between must agree with it to within the coordinates' rounding.
struct Scale {
  double a = 0, b = 0;
  double value(double pixel) const { return std::pow(10.0, a + b * pixel); }
};

Scale scale_of(const std::vector<LabelledTick>& t) {
  EXPECT_GE(t.size(), 2u);
  if (t.size() < 2) return {};
  const double l0 = std::log10(std::stod(t.front().label)),
               l1 = std::log10(std::stod(t.back().label));
  Scale s;
  s.b = (l1 - l0) / (t.back().pixel - t.front().pixel);
  s.a = l0 - s.b * t.front().pixel;
  for (const LabelledTick& k : t)
    EXPECT_NEAR(std::log10(std::stod(k.label)), s.a + s.b * k.pixel, 0.11 * std::abs(s.b))
        << k.label;
  return s;
}

// Relative error of reading a value back: coordinates have one decimal, and a decade spans more
// than 100 pixels here, so 0.05 pixel is under 0.001 in log10.
void expect_near_value(double got, double want, const std::string& what) {
  EXPECT_NEAR(std::log10(got), std::log10(want), 0.002) << what << ": " << got << " vs " << want;
}

Chart study_like_chart() {
  Chart c;
  c.title = "Error against frame time";
  for (int k = 0; k < 3; ++k) {
    Panel p;
    p.title = "scene " + std::to_string(k);
    p.x_label = "frame ms (median)";
    p.y_label = "pixels over 1 % of diag";
    p.y_floor = 1e-5;
    p.series.push_back({"linear", {81, 46.2, 25, 14}, {5e-4, 6.3e-4, 1.2e-3, 0}});
    p.series.push_back({"threshold", {21.1, 12, 9.5}, {6e-4, 2e-3, 0.011}});
    if (k == 1) p.series.push_back({"object-space", {1.8, 3.9}, {3e-4, 0}});
    std::vector<double> x, y;
    for (const Series& s : p.series) x.insert(x.end(), s.x.begin(), s.x.end());
    for (const Series& s : p.series) y.insert(y.end(), s.y.begin(), s.y.end());
    for (size_t i : pareto_front(x, y)) p.front.emplace_back(x[i], y[i]);
    c.panels.push_back(p);
  }
  return c;
}

// ---- The document ----

TEST(Svg, IsWellFormedXml) {
  REQUIRE_PARSER();
  EXPECT_EQ(xml_errors(to_svg(study_like_chart())), "");
  Chart one;
  one.panels.resize(1);
  EXPECT_EQ(xml_errors(to_svg(one)), "");
  EXPECT_EQ(xml_errors(to_svg(Chart{})), "");
  // Our own check is not the parser's: a broken document is refused.
  EXPECT_NE(xml_errors("<svg><text>a & b</text></svg>"), "");
}

TEST(Svg, HasTheRequestedSizeAndOnePanelEach) {
  const Chart c = study_like_chart();  // 3 panels in 2 columns: 2 rows
  const std::string svg = to_svg(c);
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(svg, m, std::regex("<svg [^>]*width=\"([0-9.]+)\" height=\"([0-9.]+)\"")));
  EXPECT_EQ(std::stod(m[1]), 2 * 560.0);
  EXPECT_GE(std::stod(m[2]), 2 * 400.0);
  EXPECT_LE(std::stod(m[2]), 2 * 400.0 + 80);  // the title and legend above
  EXPECT_EQ(panels_of(svg).size(), 3u);
  EXPECT_NE(svg.find(">Error against frame time</text>"), std::string::npos);
  for (int k = 0; k < 3; ++k)
    EXPECT_NE(svg.find(">scene " + std::to_string(k) + "</text>"), std::string::npos);
}

TEST(Svg, PointsLandWhereTheLogScalesSay) {
  const Chart c = study_like_chart();
  const std::vector<std::string> panels = panels_of(to_svg(c));
  ASSERT_EQ(panels.size(), c.panels.size());
  for (size_t k = 0; k < panels.size(); ++k) {
    const Scale x = scale_of(ticks(panels[k], 'x')), y = scale_of(ticks(panels[k], 'y'));
    const std::vector<Xy> drawn = circles(panels[k], "point");
    size_t i = 0;
    for (const Series& s : c.panels[k].series)
      for (size_t j = 0; j < s.x.size(); ++j, ++i) {
        ASSERT_LT(i, drawn.size());
        const std::string what =
            "panel " + std::to_string(k) + " " + s.name + " " + std::to_string(j);
        expect_near_value(x.value(drawn[i].x), s.x[j], what + " x");
        // y = 0 is drawn on the floor, where the axis starts.
        expect_near_value(y.value(drawn[i].y), std::max(s.y[j], c.panels[k].y_floor), what + " y");
      }
    EXPECT_EQ(drawn.size(), i);
  }
}

TEST(Svg, TheFrontIsTheParetoSubsetAsAStaircase) {
  Chart c;
  Panel p;
  // (30, 0.01) and (40, 0.2) are beaten by (20, 0.01); (50, 0.001) ties nothing.
  p.series.push_back({"a", {10, 20, 30, 40, 50, 60}, {0.1, 0.01, 0.01, 0.2, 0.001, 0.001}});
  const std::vector<size_t> front = pareto_front(p.series[0].x, p.series[0].y);
  ASSERT_EQ(front, (Indices{0, 1, 4}));
  // Given in any order: drawn by increasing x.
  for (size_t i : {4, 0, 1}) p.front.emplace_back(p.series[0].x[i], p.series[0].y[i]);
  c.panels.push_back(p);
  const std::string panel = panels_of(to_svg(c)).at(0);
  const Scale x = scale_of(ticks(panel, 'x')), y = scale_of(ticks(panel, 'y'));
  const std::vector<Xy> drawn = circles(panel, "front-point");
  ASSERT_EQ(drawn.size(), front.size());
  for (size_t k = 0; k < front.size(); ++k) {
    expect_near_value(x.value(drawn[k].x), p.series[0].x[front[k]], "front x");
    expect_near_value(y.value(drawn[k].y), p.series[0].y[front[k]], "front y");
  }
  // The staircase: across at the last point's height, then down to the next point.
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(panel, m, std::regex("<polyline class=\"front\" points=\"([^\"]*)\"")));
  std::vector<Xy> corners;
  std::istringstream in(m[1].str());
  for (std::string pair; in >> pair;) {
    const size_t comma = pair.find(',');
    corners.push_back({std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1))});
  }
  ASSERT_EQ(corners.size(), 2 * front.size() - 1);
  for (size_t k = 0; k < front.size(); ++k) {
    EXPECT_NEAR(corners[2 * k].x, drawn[k].x, 0.051);
    EXPECT_NEAR(corners[2 * k].y, drawn[k].y, 0.051);
    if (k == 0) continue;
    EXPECT_NEAR(corners[2 * k - 1].x, drawn[k].x, 0.051);
    EXPECT_NEAR(corners[2 * k - 1].y, drawn[k - 1].y, 0.051);
  }
}

TEST(Svg, NonFinitePointsAreLeftOutAndSaidSo) {
  Chart c;
  Panel p;
  p.series.push_back({"a", {1, kNaN, 3, kInf, 5, 0, 7}, {1, 2, -kInf, 4, 5, 6, kNaN}});
  p.front.emplace_back(kNaN, 1);
  c.panels.push_back(p);
  const std::string svg = to_svg(c);
  const std::string panel = panels_of(svg).at(0);
  EXPECT_EQ(circles(panel, "point").size(), 2u);  // (1, 1) and (5, 5)
  EXPECT_EQ(circles(panel, "front-point").size(), 0u);
  EXPECT_EQ(count(svg, "nan"), 0u);
  EXPECT_EQ(count(svg, "inf"), 0u);
  EXPECT_NE(panel.find(">6 points left out: 5 not finite, 1 not &gt; 0 (log scale)</text>"),
            std::string::npos)
      << panel;
  // With a floor, y = 0 and below is drawn on it, not left out; x = 0 still is.
  c.panels[0].series[0] = {"a", {1, 2, 0}, {0, -1, 1}};
  c.panels[0].front.clear();
  c.panels[0].y_floor = 1e-3;
  const std::string floored = panels_of(to_svg(c)).at(0);
  EXPECT_EQ(circles(floored, "point").size(), 2u);
  EXPECT_NE(floored.find(">1 point left out: 1 not &gt; 0 (log scale)</text>"), std::string::npos)
      << floored;
  const Scale y = scale_of(ticks(floored, 'y'));
  for (const Xy& d : circles(floored, "point")) expect_near_value(y.value(d.y), 1e-3, "floor");
  const std::vector<LabelledTick> yt = ticks(floored, 'y');
  ASSERT_FALSE(yt.empty());
  EXPECT_EQ(yt.front().label, "1e-3");  // the axis starts at the floor
}

TEST(Svg, TicksAreOnDecades) {
  Chart c;
  Panel p;
  p.series.push_back({"a", {1.5, 20, 900}, {2e-6, 3e-4, 0.05}});
  c.panels.push_back(p);
  const std::string panel = panels_of(to_svg(c)).at(0);
  std::vector<std::string> labels;
  for (const LabelledTick& t : ticks(panel, 'x')) labels.push_back(t.label);
  EXPECT_EQ(labels, (std::vector<std::string>{"1", "10", "100", "1000"}));
  labels.clear();
  for (const LabelledTick& t : ticks(panel, 'y')) labels.push_back(t.label);
  // Drawn bottom up: the y pixels fall as the values rise.
  EXPECT_EQ(labels, (std::vector<std::string>{"1e-6", "1e-5", "1e-4", "1e-3", "0.01", "0.1"}));
  const std::vector<LabelledTick> x = ticks(panel, 'x'), y = ticks(panel, 'y');
  for (size_t k = 2; k < x.size(); ++k)
    EXPECT_NEAR(x[k].pixel - x[k - 1].pixel, x[1].pixel - x[0].pixel, 0.11);
  for (size_t k = 1; k < y.size(); ++k) EXPECT_LT(y[k].pixel, y[k - 1].pixel);
  scale_of(x);  // and they agree with one log scale each
  scale_of(y);
  // Minor ticks between the decades: the tick path has 2..9 times each decade in range.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(panel, m, std::regex("<path class=\"ticks\" d=\"([^\"]*)\"")));
  EXPECT_GE(count(m[1].str(), "M"), 4u * 9u);

  // Under two decades in range, 2 and 5 times a decade are labelled too.
  c.panels[0].series[0] = {"a", {6, 18}, {1, 1.5}};
  labels.clear();
  for (const LabelledTick& t : ticks(panels_of(to_svg(c)).at(0), 'x')) labels.push_back(t.label);
  EXPECT_EQ(labels, (std::vector<std::string>{"5", "10", "20"}));
}

TEST(Svg, EmptyInputIsHandled) {
  const std::string none = to_svg(Chart{});
  EXPECT_EQ(panels_of(none).size(), 0u);
  EXPECT_NE(none.find(">no data</text>"), std::string::npos);
  EXPECT_NE(none.find("</svg>"), std::string::npos);

  Chart c;
  c.panels.resize(2);                                // no series at all
  c.panels[1].series.push_back({"a", {kNaN}, {1}});  // nothing drawable
  const std::vector<std::string> panels = panels_of(to_svg(c));
  ASSERT_EQ(panels.size(), 2u);
  EXPECT_NE(panels[0].find(">no data</text>"), std::string::npos);
  EXPECT_NE(panels[1].find(">no data (1 point left out: 1 not finite)</text>"), std::string::npos);
  for (const std::string& p : panels) {
    EXPECT_EQ(circles(p, "point").size(), 0u);
    EXPECT_GE(ticks(p, 'x').size(), 2u);  // an axis still, from 1 to 10
  }
  if (parser() != Parser::kNone) {
    EXPECT_EQ(xml_errors(none), "");
    EXPECT_EQ(xml_errors(to_svg(c)), "");
  }
}

TEST(Svg, SpecialCharactersAreEscaped) {
  EXPECT_EQ(xml_escape("a & b <c> \"d\" 'e'"), "a &amp; b &lt;c&gt; &quot;d&quot; &apos;e&apos;");
  EXPECT_EQ(xml_escape("ms (µ, ², 🙂)\ttab"), "ms (µ, ², 🙂)\ttab");  // UTF-8 kept
  const std::string bad = "\xEF\xBF\xBD";
  EXPECT_EQ(xml_escape(std::string("x\x01y\0z", 5)), "x" + bad + "y" + bad + "z");
  EXPECT_EQ(xml_escape("\xff\xc3"), bad + bad);            // not UTF-8; a sequence cut short
  EXPECT_EQ(xml_escape("\xc0\xaf"), bad + bad);            // overlong
  EXPECT_EQ(xml_escape("\xef\xbf\xbe"), bad + bad + bad);  // U+FFFE

  REQUIRE_PARSER();
  const std::string nasty = "a & b <c> \"d\" 'e' </text>]]>";
  Chart c;
  c.title = nasty;
  Panel p;
  p.title = nasty + " panel";
  p.x_label = "x " + nasty;
  p.y_label = "y " + nasty;
  p.series.push_back({nasty + " series", {1, 2}, {1, 2}});
  p.series.push_back({"\x01\xff", {1}, {3}});
  c.panels.push_back(p);
  const std::string svg = to_svg(c);
  ASSERT_EQ(xml_errors(svg), "");
  // The parser reads each text back as given.
  EXPECT_EQ(parsed_text(svg, "title"), nasty);
  EXPECT_EQ(parsed_text(svg, "panel-title"), nasty + " panel");
  EXPECT_EQ(parsed_text(svg, "x-label"), "x " + nasty);
  EXPECT_EQ(parsed_text(svg, "y-label"), "y " + nasty);
  EXPECT_NE(parsed_text(svg, "legend").find(nasty + " series"), std::string::npos);
}

TEST(Svg, ASeriesKeepsItsColourByNameAcrossPanels) {
  Chart c;
  c.panels.resize(2);
  c.panels[0].series = {{"a", {1}, {1}}, {"b", {2}, {2}}};
  c.panels[1].series = {{"b", {1}, {1}}, {"c", {2}, {2}}, {"a", {3}, {3}}};
  const std::string svg = to_svg(c);
  auto fills = [](const std::string& panel) {
    std::vector<std::string> out;
    const std::regex re("<g class=\"series\" fill=\"(#[0-9a-f]{6})\"");
    for (std::sregex_iterator it(panel.begin(), panel.end(), re), end; it != end; ++it)
      out.push_back((*it)[1]);
    return out;
  };
  const std::vector<std::string> p0 = fills(panels_of(svg).at(0)), p1 = fills(panels_of(svg).at(1));
  ASSERT_EQ(p0.size(), 2u);
  ASSERT_EQ(p1.size(), 3u);
  EXPECT_NE(p0[0], p0[1]);
  EXPECT_EQ(p1[0], p0[1]);  // b
  EXPECT_EQ(p1[2], p0[0]);  // a
  EXPECT_NE(p1[1], p0[0]);  // c is new
  EXPECT_NE(p1[1], p0[1]);
  // The legend has each name once, in order of first appearance, and no front entry here.
  const size_t legend = svg.find("<g class=\"legend\">");
  ASSERT_NE(legend, std::string::npos);
  const std::string entries = svg.substr(legend, svg.find("</g>", legend) - legend);
  EXPECT_EQ(count(entries, "<text"), 3u);
  EXPECT_LT(entries.find(">a<"), entries.find(">b<"));
  EXPECT_LT(entries.find(">b<"), entries.find(">c<"));
  EXPECT_EQ(entries.find("Pareto front"), std::string::npos);
  EXPECT_NE(to_svg(study_like_chart()).find(">Pareto front</text>"), std::string::npos);
}

TEST(Svg, BadArgumentsThrow) {
  Chart c = study_like_chart();
  c.columns = 0;
  EXPECT_THROW(to_svg(c), Error);
  c = study_like_chart();
  c.panel_width = 50;
  EXPECT_THROW(to_svg(c), Error);
  c = study_like_chart();
  c.panel_height = 20000;
  EXPECT_THROW(to_svg(c), Error);
  c = study_like_chart();
  c.panels[0].y_floor = kInf;
  EXPECT_THROW(to_svg(c), Error);
  c.panels[0].y_floor = -1;
  EXPECT_THROW(to_svg(c), Error);
  c = study_like_chart();
  c.panels[1].series[0].y.pop_back();
  try {
    to_svg(c);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'linear' of panel 'scene 1'"), std::string::npos)
        << e.what();
  }
}

TEST(Svg, ExtremeValuesStayFinite) {
  Chart c;
  Panel p;
  p.series.push_back({"a", {1e-320, 1e300, 5e-324}, {1.7e308, 1e-310, 1}});
  c.panels.push_back(p);
  const std::string svg = to_svg(c);
  EXPECT_EQ(circles(panels_of(svg).at(0), "point").size(), 3u);
  EXPECT_EQ(count(svg, "nan"), 0u);
  EXPECT_EQ(count(svg, "inf"), 0u);
  EXPECT_LE(count(svg, "class=\"x-tick\""), 10u);  // every 76th decade of 600
  if (parser() != Parser::kNone) {
    EXPECT_EQ(xml_errors(svg), "");
  }
}

TEST(Svg, WriteSvgWritesTheDocument) {
  const Chart c = study_like_chart();
  const TempFile file("");
  write_svg(file.path().string(), c);
  std::ifstream in(file.path(), std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_EQ(s.str(), to_svg(c));
  EXPECT_THROW(write_svg("/nonexistent_dir/chart.svg", c), Error);
}

}  // namespace
}  // namespace raywarp::chart
