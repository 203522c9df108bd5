// Charts as SVG: panels of points on log-log axes, one colour per series name, with a Pareto
// front, for plots such as image error against frame time (`raywarp study`'s pareto.svg).
//
// Why SVG written directly, rather than a plotting library: no well-kept C++ plotting library is
// packaged in Debian 12, and gnuplot (or a Python stack) would be a runtime dependency that every
// user of `raywarp study` must install. An SVG is plain text: it is written here in a few hundred
// lines with no dependency, it diffs in review, it is resolution independent, and every browser
// and the Markdown renderers of the docs show it (a hover over a point shows its values).
//
// Coordinates are SVG user units (pixels at 100 %), absolute throughout (no transforms except the
// rotation of the y axis labels), y growing downwards. Elements carry classes a reader or a test
// can find them by: g.panel per panel, circle.point per data point (cx, cy its centre),
// circle.front-point and polyline.front for the Pareto front, text.x-tick and text.y-tick for the
// labelled ticks, text.note for what a panel leaves out, g.legend.
#pragma once
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace raywarp::chart {

struct Series {
  std::string name;          // legend entry and colour key; an empty name has no legend entry
  std::vector<double> x, y;  // data points, same length
};

struct Panel {
  std::string title, x_label, y_label;
  std::vector<Series> series;
  // Pareto front points, drawn as a black staircase through hollow circles ("Pareto front" in
  // the legend). Order does not matter.
  std::vector<std::pair<double, double>> front;
  // If > 0: the y axis starts here, and y values below it (0 included) are drawn on it, e.g. an
  // error of 0 ("no pixel over a threshold") on a log axis.
  double y_floor = 0;
};

struct Chart {
  std::string title;  // above the legend; none if empty
  std::vector<Panel> panels;
  int columns = 2;                            // panels per row (fewer if there are fewer panels)
  int panel_width = 560, panel_height = 400;  // each panel's cell, axes and labels included
};

// The chart as an SVG document. Both axes are logarithmic: ticks on every decade (labelled
// "0.01", "1", "1000", "1e-3", "1e4"; also 2 and 5 times a decade when fewer than two decades are
// in range) with unlabelled minor ticks between, ranges padded around the data and rounded out
// to half decades. A point with a coordinate that is not finite, or not > 0 on the log scale (x,
// or y without a floor), is left out, and the panel says how many in a note. A panel without a
// point says "no data"; a chart without panels is one line of text. Colours: a fixed palette of
// 10 (matplotlib's tab10) in order of first appearance of each name over all panels, so a name
// keeps its colour everywhere; the legend, above the panels, has each name once. Labels and
// titles are escaped (xml_escape). Throws Error if columns < 1, a panel size is outside
// [100, 10000], a y_floor is negative or not finite, or a series' x and y differ in length.
std::string to_svg(const Chart& chart);

// to_svg into `path`, atomically (write_file_atomic). Throws Error naming the path.
void write_svg(const std::string& path, const Chart& chart);

// Indices of the points that no other point beats in both x and y (smaller is better in both),
// sorted by increasing x, ties in x by index. A point equal to another in one coordinate and worse
// in the other is dominated; equal points do not dominate each other, so duplicates on the front
// are all returned. Points with a NaN coordinate are ignored; infinities compare as usual.
// Throws Error if x and y differ in length.
std::vector<size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y);

// Text for SVG character data and attribute values: & < > " ' as entities; control characters
// (which XML 1.0 forbids, but tab and newline) and bytes that are not UTF-8 as U+FFFD.
std::string xml_escape(const std::string& text);

}  // namespace raywarp::chart
