// Charts written as images: scatter and line panels on log or linear axes, with a Pareto front,
// for plots such as image error against frame time. Self-contained: text is stb_easy_font's
// bitmap font, rasterised here; the result is an Image to pass to write_png.
//
// Conventions: pixel (i, j) covers [i, i + 1) x [j, j + 1), row 0 at the top, so the centre of a
// pixel is (i + 0.5, j + 0.5) and the pixel holding the continuous coordinate p is floor(p).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "library/image.h"

namespace raywarp::plot {

struct Series {
  std::string name;          // legend entry; an empty name has no entry
  std::vector<double> x, y;  // data points, same length; NaN and +-inf points are skipped
  bool connect = true;       // draw a polyline through the points sorted by x
};

struct Panel {
  std::string title;
  std::string x_label, y_label;
  bool log_x = true, log_y = true;
  // Colours come from a fixed palette by series index; a name met again in a later panel keeps
  // the colour it had first (series_colours).
  std::vector<Series> series;
  // Pareto front points, drawn as a thick black staircase with hollow circles and a legend entry
  // "Pareto front". Order does not matter.
  std::vector<std::pair<double, double>> front;
  // If > 0 and y is logarithmic: y values below it are drawn at y_floor (e.g. "no pixel over a
  // threshold", an error of 0), and the y axis starts at it.
  double y_floor = 0;
};

// Renders the panels row by row in a grid of min(columns, panels.size()) columns, each panel
// panel_width x panel_height pixels; panel k has its top-left corner at
// ((k % columns) * panel_width, (k / columns) * panel_height). White background, axes with ticks
// and labels, the title above, a legend inside the plot area in the corner that covers the fewest
// points. Values on a log axis that are <= 0 are drawn at the axis minimum. No panels give one
// empty panel. Throws Error if columns, panel_width or panel_height is <= 0, if the image would
// be larger than 2^26 pixels, or if a series' x and y differ in length.
Image render_chart(const std::vector<Panel>& panels, int columns, int panel_width = 480,
                   int panel_height = 360);

// Indices of the points that no other point beats in both x and y (smaller is better in both),
// sorted by increasing x, ties in x by index. A point equal to another in one coordinate and worse
// in the other is dominated; equal points do not dominate each other, so duplicates on the front
// are all returned. Points with a NaN coordinate are ignored; infinities compare as usual.
// Throws Error if x and y differ in length.
std::vector<size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y);

// Below: the layout render_chart uses, exposed so that a caller (or a test) can find where a
// value is drawn.

// One axis: a data range mapped linearly, or linearly in log10, onto a pixel span.
struct Axis {
  double lo = 0, hi = 1;  // data range, lo < hi; both > 0 on a log axis
  bool log = false;
  // Continuous pixel coordinates (panel-local) of lo and hi. For a y axis pixel_lo > pixel_hi,
  // since rows grow downwards.
  double pixel_lo = 0, pixel_hi = 1;
  // Values outside [lo, hi], including values <= 0 on a log axis, map to the nearest end; NaN
  // maps to lo's end too (callers skip it).
  double to_pixel(double v) const;
};

struct Tick {
  double value = 0;
  std::string label;  // empty for an unlabelled minor tick
};
// Decades on a log axis ("0.01", "1", "1000", "1e-3", "1e4"), with 2 and 5 times a decade when
// fewer than two decades fall in the range, and unlabelled minor ticks 2..9 times a decade;
// multiples of 1, 2 or 5 times a power of ten on a linear axis, about five in the range.
std::vector<Tick> axis_ticks(const Axis& axis);

// Where render_chart draws a panel, in coordinates local to the panel's top-left corner. The plot
// area is the pixel rectangle [left, right] x [top, bottom], frame included; the axes map their
// ranges onto the centres of the frame's pixels.
struct PanelLayout {
  Axis x, y;
  int left = 0, top = 0, right = 0, bottom = 0;
};
PanelLayout panel_layout(const Panel& panel, int panel_width, int panel_height);

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb& o) const { return r == o.r && g == o.g && b == o.b; }
};
// The colour of each series of each panel, [panel][series]: palette entries in order of first
// appearance of each name (so panel 0's series k has entry k), an empty name always taking a new
// one. The palette has 10 colours, then repeats.
std::vector<std::vector<Rgb>> series_colours(const std::vector<Panel>& panels);

}  // namespace raywarp::plot
