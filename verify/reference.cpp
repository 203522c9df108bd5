#include "verify/reference.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "base/error.h"
#include "base/parallel.h"
#include "library/cylindrical.h"
#include "library/triangle_bvh.h"
#include "verify/cpu_shading.h"

namespace raywarp {

namespace {

using cpu_shading::check_image_size;
using cpu_shading::put_colour;
using cpu_shading::shade;
using Vec3 = Eigen::Vector3d;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

Vec3 albedo_of(const RenderSettings& settings, HitKind kind) {
  switch (kind) {
    case HitKind::Inside:
      return settings.inside_colour;
    case HitKind::CutFace:
      return settings.cut_colour;
    case HitKind::Surface:
      break;
  }
  return settings.colour;
}

// ---------------------------------------------------------------------------------------------
// The ray cast (Correa & Silver 2007, section 3), as in shaders/march.glsl's raywarp_cast.

// One sample of the ray, as the shader's Sample: f at the preimage (valid when it lies in the
// box), and the alpha map A.
struct Sample {
  double f = 0.0, a = -1.0;
  bool valid = false;
};

// Where the textures are read: M p' (BoxTextures::texture_map), as the shader's texture_point().
Vec3 texture_point(const BoxTextures& box, const Vec3& p_def) {
  return (box.texture_map * p_def.homogeneous()).head<3>();
}

// D and w at p', read at M p', as the shader's deformation().
Eigen::Vector4d deformation_at(const BoxTextures& box, const Vec3& p_def) {
  if (box.cylindrical())
    return cylindrical_displacement(box.deformation.grid, box.cylindrical_axis, p_def);
  return box.deformation.grid.sample(texture_point(box, p_def));
}

// A at p', read at M p', as the shader's alpha_at().
double alpha_at(const BoxTextures& box, const Vec3& p_def) {
  if (box.cylindrical()) return cylindrical_alpha(box.alpha.grid, box.cylindrical_axis, p_def);
  return box.alpha.grid.sample(box.moves_nothing ? p_def : texture_point(box, p_def)).value();
}

// `beyond_ok`: the previous sample lay in the box. Then, where D is the identity (|D| below the
// seam tolerance), a point beyond the box is read (D = 0 everywhere: beyond every face), and so is
// a point within a deformation texel of a face where the interpolated w falls below 1/2: the texel
// beyond the face holds no preimage, but the point's preimage is itself, in the box.

Sample sample_at(const BoxTextures& box, const Vec3& p_def, bool beyond_ok) {
  Sample s;
  if (box.moves_nothing) {
    s.valid = beyond_ok || box.box.contains_local(p_def);
    s.f = s.valid ? implicit_value(box, p_def) : -implicit_background(box);
  } else {
    Eigen::Vector4d dv = deformation_at(box, p_def);
    Vec3 p = p_def + dv.head<3>();
    const Vec3& h = box.box.half_extents;
    const bool near_face = (p_def.cwiseAbs() - h + deformation_step(box)).maxCoeff() > 0.0;
    const bool identity = dv.head<3>().norm() < kSeamVoxels * implicit_spacing(box);
    // Read through M, a texel beyond the box holding the identity is the identity here too.
    const bool mapped_out = !box.texture_map.isIdentity(0.0) && identity &&
                            !box.box.contains_local(texture_point(box, p_def));
    s.valid = box.box.contains_local(p) &&
              (dv.w() >= 0.5 || mapped_out || (beyond_ok && near_face && identity));
    s.f = s.valid ? implicit_value(box, p) : -implicit_background(box);
  }
  if (box.has_cut) s.a = alpha_at(box, p_def);
  return s;
}

// The surface function: f, or eq. 7's shell f^ = tau - f where f > tau / 2.
double surface(const BoxTextures& box, double f) {
  return box.has_cut && box.cut_mode == CutMode::ThickShell ? std::min(f, box.shell_thickness - f)
                                                            : f;
}

// The solid the ray looks for (> 0 inside): the surface minus the cut.
double value(const BoxTextures& box, const Sample& s) {
  if (!s.valid) return -implicit_background(box);
  if (box.has_cut && box.cut_mode != CutMode::Hollow) return std::min(surface(box, s.f), -s.a);
  return s.f;
}

constexpr double kSqrt3 = 1.7320508075688772;
// A grazing ray's search (shaders/march.glsl, raywarp_cast): golden-section steps for the value's
// peak, and how near the surface (of the three samples' span) their parabola's peak must come.
constexpr double kGolden = 0.6180339887498949;
constexpr int kGrazeSteps = 6;
constexpr double kGrazeMargin = 0.1;
constexpr double kGrazeHitVoxels = 0.02;  // a grazing peak this near the surface is the hit

// The peak of the parabola through (x0, y0), (x1, y1), (x2, y2), x0 < x1 < x2, y1 above both
// others.
double parabola_peak(double x0, double x1, double x2, double y0, double y1, double y2) {
  const double d1 = (y1 - y0) / std::max(x1 - x0, 1e-30), d2 = (y2 - y1) / std::max(x2 - x1, 1e-30);
  const double a = (d2 - d1) / std::max(x2 - x0, 1e-30);
  const double b = (d1 * (x2 - x1) + d2 * (x1 - x0)) / std::max(x2 - x0, 1e-30);
  return a < 0.0 ? y1 - b * b / (4.0 * a) : y1;
}

// How far the ray may advance without passing a hit (the shader's skip_distance).
double skip_distance(const BoxTextures& box, const Sample& s) {
  if (!s.valid) return 0.0;
  if (box.has_cut && s.a > 0.0) return s.a / kSqrt3;
  if (box.uses_depth_cube) return 0.0;  // its |f| bounds no distance (the cut's skip stays)
  double room = box.has_cut && box.cut_mode == CutMode::Hollow ? std::abs(s.f) : -surface(box, s.f);
  double skip = room / (kSqrt3 * box.lipschitz);
  if (box.has_cut && !box.moves_nothing) skip = std::min(skip, -s.a - cut_margin(box));
  return skip;
}

Vec3 displacement(const BoxTextures& box, const Vec3& p_def) {
  if (box.moves_nothing) return Vec3::Zero();
  return deformation_at(box, p_def).head<3>();
}

// The `bounded` tracer's function (see StepBounds): g = min(f(p), b(p), (w - 1/2) / L_w) at
// p = p' + D(p'), > 0 exactly where a sample is inside; `p` gets the preimage.
double bounded_g(const BoxTextures& box, const Vec3& p_def, Vec3* p) {
  const Eigen::Vector4d dv = deformation_at(box, p_def);
  *p = p_def + dv.head<3>();
  double g = std::min(implicit_value(box, *p), (box.box.half_extents - p->cwiseAbs()).minCoeff());
  if (box.step_bounds.validity_lipschitz > 0.0)
    g = std::min(g, (dv.w() - 0.5) / box.step_bounds.validity_lipschitz);
  return g;
}

// Sphere tracing of g over [t0, t1] (the shader's RAYWARP_SAMPLING_BOUNDED), with the linear
// search's extra samples just before each box face plane (`crossings`, ray parameters). A sample
// with g > -epsilon is the hit (lo = hi = its t; if g > 0 after a step, which only rounding allows,
// lo is the previous sample). At a face sample, a value within `seam` of the surface also is, as
// in the linear search. Returns whether it hit; the steps never pass a point where g > 0.
bool bounded_search(const BoxTextures& box, const Vec3& o, const Vec3& d, double t0, double t1,
                    const double (&crossings)[6], const RenderSettings& settings, double* lo,
                    double* hi) {
  if (box.step_bounds.empty())
    throw Error(
        "ray_cast_box: sampling \"bounded\" needs the box's step bounds "
        "(bake_step_bounds)");
  const double h = implicit_spacing(box);
  const double epsilon = settings.hit_epsilon_voxels * h, seam = kSeamVoxels * h;
  double t = t0;
  Vec3 p;
  double g = bounded_g(box, o + t * d, &p);
  if (g > -epsilon) {
    *lo = *hi = t;
    return true;
  }
  for (int i = 1; i <= settings.max_steps + 6 && t < t1; ++i) {
    double next_crossing = kInfinity;
    for (double tc : crossings)
      next_crossing = tc > t ? std::min(next_crossing, tc) : next_crossing;
    const StepBound bound = step_bound_at(box.step_bounds, o + t * d, p);
    const double target = std::min(t + std::min(-g / bound.lipschitz, bound.longest), t1);
    const bool at_face = next_crossing < target;
    const double tn = at_face ? next_crossing : target;
    Vec3 pn;
    const double gn = bounded_g(box, o + tn * d, &pn);
    if (gn > 0.0) {  // only by rounding: refine between the two samples
      *lo = t;
      *hi = tn;
      return true;
    }
    if (gn > -epsilon || (at_face && value(box, sample_at(box, o + tn * d, true)) > -seam)) {
      *lo = *hi = tn;
      return true;
    }
    t = tn;
    g = gn;
    p = pn;
  }
  return false;
}

// Outward normal of the deformed surface, eq. 5: (I + J_D)^T n(p' + D(p')) with n = -grad f
// (f > 0 inside), both derivatives by central differences of the textures at their own
// spacing (not normalised).
Vec3 deformed_normal(const BoxTextures& box, const Vec3& p_def) {
  Vec3 p = p_def + displacement(box, p_def);
  const double hf = implicit_spacing(box);
  const Vec3 hd = deformation_step(box);
  Vec3 grad_f;
  Eigen::Matrix3d jd;  // columns: dD/dx, dD/dy, dD/dz
  for (int a = 0; a < 3; ++a) {
    Vec3 ef = Vec3::Unit(a) * hf, ed = Vec3::Unit(a) * hd[a];
    grad_f[a] = (implicit_value(box, p + ef) - implicit_value(box, p - ef)) / (2.0 * hf);
    jd.col(a) = (displacement(box, p_def + ed) - displacement(box, p_def - ed)) / (2.0 * hd[a]);
  }
  return (Eigen::Matrix3d::Identity() + jd).transpose() * (-grad_f);
}

// The cut face's outward normal (into the cut): grad A (eq. 6), not normalised.
Vec3 alpha_gradient(const BoxTextures& box, const Vec3& p_def) {
  const Vec3 h = alpha_step(box);
  Vec3 g;
  for (int a = 0; a < 3; ++a)
    g[a] = (alpha_at(box, p_def + h[a] * Vec3::Unit(a)) -
            alpha_at(box, p_def - h[a] * Vec3::Unit(a))) /
           (2.0 * h[a]);
  return g;
}

Vec3 unit_or(const Vec3& n, const Vec3& fallback) {
  double len = n.norm();
  return len > 0.0 && std::isfinite(len) ? Vec3(n / len) : fallback;
}

// The parameter range of a local-frame ray inside the box's ray-cast region, clipped to
// [t_min, t_max]. Empty when t0 >= t1.
std::pair<double, double> texture_range(const BoxTextures& box, const Vec3& o, const Vec3& d,
                                        double t_min, double t_max) {
  double t0 = t_min, t1 = t_max;
  const Eigen::AlignedBox3d region = ray_cast_region(box);
  if (!clip_ray_to_box(o, d, region.min(), region.max(), t0, t1)) return {kInfinity, -kInfinity};
  return {t0, t1};
}

// ---------------------------------------------------------------------------------------------
// Splitting triangles at the box faces (ground_truth_mesh).

using Polygon = std::vector<Vec3>;  // convex, in the box's local frame, source orientation

// Splits `poly` by the plane side * q[axis] = h into the part on the box's side (<= h) and the
// part beyond. A polygon that only touches the plane goes wholly to one side, so no area is
// duplicated; new vertices are put exactly on the plane, so no piece straddles it.
void split_polygon(const Polygon& poly, int axis, double side, double h, Polygon& inner,
                   Polygon& outer) {
  inner.clear();
  outer.clear();
  std::vector<double> s(poly.size());
  double smin = kInfinity, smax = -kInfinity;
  for (size_t i = 0; i < poly.size(); ++i) {
    s[i] = side * poly[i][axis] - h;
    smin = std::min(smin, s[i]);
    smax = std::max(smax, s[i]);
  }
  if (smax <= 0.0) {
    inner = poly;
    return;
  }
  if (smin >= 0.0) {
    outer = poly;
    return;
  }
  for (size_t i = 0; i < poly.size(); ++i) {
    size_t j = (i + 1) % poly.size();
    if (s[i] <= 0.0) inner.push_back(poly[i]);
    if (s[i] >= 0.0) outer.push_back(poly[i]);
    if ((s[i] < 0.0 && s[j] > 0.0) || (s[i] > 0.0 && s[j] < 0.0)) {
      Vec3 x = poly[i] + (s[i] / (s[i] - s[j])) * (poly[j] - poly[i]);
      x[axis] = side * h;
      inner.push_back(x);
      outer.push_back(x);
    }
  }
  if (inner.size() < 3) inner.clear();
  if (outer.size() < 3) outer.clear();
}

// True when all of the triangle lies beyond one face plane of the box (local frame).
bool beyond_one_face(const std::array<Vec3, 3>& q, const Vec3& half) {
  for (int a = 0; a < 3; ++a) {
    if (q[0][a] > half[a] && q[1][a] > half[a] && q[2][a] > half[a]) return true;
    if (q[0][a] < -half[a] && q[1][a] < -half[a] && q[2][a] < -half[a]) return true;
  }
  return false;
}

// A mesh under construction.
struct MeshBuilder {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> faces;
  int add(const Vec3& v) {
    vertices.push_back(v);
    return static_cast<int>(vertices.size()) - 1;
  }
  Mesh finish() {
    Mesh m;
    m.V.resize(static_cast<Eigen::Index>(vertices.size()), 3);
    m.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (size_t i = 0; i < vertices.size(); ++i) m.V.row(i) = vertices[i].transpose();
    for (size_t i = 0; i < faces.size(); ++i) m.F.row(i) = faces[i].transpose();
    return m;
  }
};

// Bound on the faces ground_truth_mesh may produce (~2.4 GB of mesh data), checked before the
// subdivision of each triangle is allocated.
constexpr long kMaxGroundTruthFaces = 50'000'000;

// Uniform subdivision of triangle (a, b, c) into n^2 triangles of the same orientation, each
// vertex mapped by `map` before it is stored.
// Known issue: n is chosen per triangle, so two neighbours with different n meet at
// T-junctions; after a curved F the gaps there are O(max_edge^2 |F''|), well below a pixel
// when max_edge is.
template <class Map>
void add_subdivided(MeshBuilder& out, const Vec3& a, const Vec3& b, const Vec3& c, int n,
                    const Map& map) {
  if (static_cast<long>(out.faces.size()) + static_cast<long>(n) * n > kMaxGroundTruthFaces)
    throw Error("ground_truth_mesh: more than " + std::to_string(kMaxGroundTruthFaces) +
                " triangles: choose a larger max_edge");
  // Vertex (i, j) = a + i/n (b - a) + j/n (c - a), i + j <= n, stored row by row in j.
  std::vector<int> index;
  index.reserve(static_cast<size_t>(n + 1) * (n + 2) / 2);
  auto at = [&](int i, int j) { return index[j * (n + 1) - j * (j - 1) / 2 + i]; };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i + j <= n; ++i)
      index.push_back(out.add(map(a + (static_cast<double>(i) / n) * (b - a) +
                                  (static_cast<double>(j) / n) * (c - a))));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i + j < n; ++i) {
      out.faces.emplace_back(at(i, j), at(i + 1, j), at(i, j + 1));
      if (i + j < n - 1) out.faces.emplace_back(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
    }
}

// ---------------------------------------------------------------------------------------------
// Rasterisation (rasterize).

// A vertex in clip space with its linear eye depth, which is affine in the object position and
// so interpolates with the same weights as the clip coordinates.
struct ClipVertex {
  Eigen::Vector4d clip;
  double depth;
};

// A vertex on screen: pixel coordinates (row 0 at the top, pixel centres at +0.5), 1/w and
// depth/w, both affine in screen space (perspective-correct interpolation).
struct ScreenVertex {
  double x, y, inv_w, depth_over_w;
};

struct ScreenPolygon {
  std::array<ScreenVertex, 8> v;  // a triangle clipped by two planes has at most 5 vertices
  int count = 0;
};

// Sutherland-Hodgman against one clip-space plane, keeping dist(v) >= 0.
template <class Dist>
int clip_polygon(const ClipVertex* in, int n, ClipVertex* out, const Dist& dist) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const ClipVertex &p = in[i], &q = in[(i + 1) % n];
    double dp = dist(p.clip), dq = dist(q.clip);
    if (dp >= 0.0) out[m++] = p;
    if ((dp >= 0.0) != (dq >= 0.0)) {
      double s = dp / (dp - dq);
      out[m++] = ClipVertex{p.clip + s * (q.clip - p.clip), p.depth + s * (q.depth - p.depth)};
    }
  }
  return m;
}

// The first and last pixel (of `size`) whose centre, at index + 0.5, is >= lo or <= hi; the
// range is empty when first > last.
int first_centre(double lo, int size) {
  return static_cast<int>(std::clamp(std::ceil(lo - 0.5), 0.0, static_cast<double>(size)));
}
int last_centre(double hi, int size) {
  return static_cast<int>(std::clamp(std::floor(hi - 0.5), -1.0, size - 1.0));
}

class Rasterizer {
 public:
  Rasterizer(const Mesh& mesh, const Camera& camera, int width, int height)
      : mesh_(mesh), width_(width), height_(height) {
    Eigen::Matrix4d view_proj =
        camera.projection_matrix(static_cast<double>(width) / height) * camera.view();
    int nv = static_cast<int>(mesh.V.rows());
    vertices_.resize(nv);
    constexpr int kChunk = 4096;
    parallel_for((nv + kChunk - 1) / kChunk, [&](int chunk) {
      for (int v = chunk * kChunk; v < std::min(nv, (chunk + 1) * kChunk); ++v) {
        Vec3 p = mesh.V.row(v).transpose();
        vertices_[v] = ClipVertex{view_proj * p.homogeneous(), camera.depth_of(p)};
      }
    });
  }

  // Face f clipped to the near and far planes (-w <= z <= w) and projected to the screen.
  ScreenPolygon project(int f) const {
    std::array<ClipVertex, 8> a, b;
    int n = 3;
    bool inside = true;
    for (int c = 0; c < 3; ++c) {
      a[c] = vertices_[mesh_.F(f, c)];
      const Eigen::Vector4d& h = a[c].clip;
      inside = inside && h.z() >= -h.w() && h.z() <= h.w();
    }
    if (!inside) {
      n = clip_polygon(a.data(), n, b.data(),
                       [](const Eigen::Vector4d& h) { return h.z() + h.w(); });
      n = clip_polygon(b.data(), n, a.data(),
                       [](const Eigen::Vector4d& h) { return h.w() - h.z(); });
    }
    ScreenPolygon out;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector4d& h = a[i].clip;
      if (!(h.w() > 0.0)) return ScreenPolygon{};
      double inv_w = 1.0 / h.w();
      out.v[i] = ScreenVertex{(h.x() * inv_w + 1.0) * 0.5 * width_,
                              (1.0 - h.y() * inv_w) * 0.5 * height_, inv_w, a[i].depth * inv_w};
    }
    out.count = n < 3 ? 0 : n;
    return out;
  }

  // Rows whose pixel centres the face may cover, [first, last]; first > last when none.
  std::pair<int, int> rows(int f) const {
    ScreenPolygon poly = project(f);
    if (poly.count == 0) return {1, 0};
    double lo = kInfinity, hi = -kInfinity;
    for (int i = 0; i < poly.count; ++i) {
      lo = std::min(lo, poly.v[i].y);
      hi = std::max(hi, poly.v[i].y);
    }
    if (!std::isfinite(lo) || !std::isfinite(hi)) return {1, 0};
    return {first_centre(lo, height_), last_centre(hi, height_)};
  }

  // Draws face f into rows [row0, row1] of the z-buffer `depth` and the face-id buffer.
  void draw(int f, int row0, int row1, std::vector<double>& depth, std::vector<int>& face) const {
    ScreenPolygon poly = project(f);
    for (int k = 1; k + 1 < poly.count; ++k)
      draw_triangle(poly.v[0], poly.v[k], poly.v[k + 1], f, row0, row1, depth, face);
  }

 private:
  void draw_triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c, int f,
                     int row0, int row1, std::vector<double>& depth, std::vector<int>& face) const {
    auto edge = [](const ScreenVertex& p, const ScreenVertex& q, double x, double y) {
      return (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x);
    };
    double area = edge(a, b, c.x, c.y);
    if (area == 0.0 || !std::isfinite(area)) return;
    int y0 = std::max(row0, first_centre(std::min({a.y, b.y, c.y}), height_));
    int y1 = std::min(row1, last_centre(std::max({a.y, b.y, c.y}), height_));
    int x0 = first_centre(std::min({a.x, b.x, c.x}), width_);
    int x1 = last_centre(std::max({a.x, b.x, c.x}), width_);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double px = x + 0.5, py = y + 0.5;
        double wa = edge(b, c, px, py) / area, wb = edge(c, a, px, py) / area,
               wc = edge(a, b, px, py) / area;
        if (wa < 0.0 || wb < 0.0 || wc < 0.0) continue;
        double inv_w = wa * a.inv_w + wb * b.inv_w + wc * c.inv_w;
        double d = (wa * a.depth_over_w + wb * b.depth_over_w + wc * c.depth_over_w) / inv_w;
        size_t i = static_cast<size_t>(y) * width_ + x;
        if (d < depth[i]) {
          depth[i] = d;
          face[i] = f;
        }
      }
  }

  const Mesh& mesh_;
  int width_, height_;
  std::vector<ClipVertex> vertices_;
};

}  // namespace

double jacobian_step(const BoxTextures& box, const Vec3& p_def, const Vec3& v, double ds) {
  const double h = deformation_step(box).minCoeff();
  const Vec3 jv = (displacement(box, p_def + h * v) - displacement(box, p_def - h * v)) / (2.0 * h);
  return ds / std::clamp((v + jv).norm(), 0.25, 16.0);
}

std::optional<RayHit> ray_cast_box(const BoxTextures& box, const Eigen::Vector3d& origin,
                                   const Eigen::Vector3d& direction, double t0, double t1,
                                   const RenderSettings& settings) {
  if (!(t0 < t1)) return std::nullopt;
  const Vec3& o = origin;
  const Vec3& d = direction;
  const bool hollow = box.has_cut && box.cut_mode == CutMode::Hollow;
  const bool skip = skipping_pays(box, settings.step_voxels, settings.skipping);
  auto at = [&](double t, bool beyond_ok) { return sample_at(box, o + t * d, beyond_ok); };
  // Linear search (eq. 3), bounded by max_steps.
  const double step = settings.step_voxels * implicit_spacing(box);
  // Besides the regular samples (or skips), one just before each crossing of a box face plane:
  // that catches slivers of S_D thinner than a step that end on a face (at the seam with the
  // raster pass, where a missed sliver would show the mesh's inside).
  const double before = 1e-3 * step;
  const double seam = kSeamVoxels * implicit_spacing(box);
  double crossings[6];
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s)
      crossings[2 * a + s] =
          d[a] != 0.0 ? ((s ? 1.0 : -1.0) * box.box.half_extents[a] - o[a]) / d[a] - before
                      : -kInfinity;
  double t = t0, lo = t0, hi = t0;
  bool was_in_box = box.box.contains_local(o + t0 * d);
  Sample s = at(t0, false);
  bool hit = !hollow && value(box, s) > 0.0, front = true;
  double t_before = t0, v_before = -1e30;  // the sample before the last one
  bool grazed = false;                     // the first grazing bracket, if any
  double graze_l = t0, graze_r = t0;
  const bool bounded = settings.sampling == Sampling::Bounded && !box.has_cut && !box.moves_nothing;
  if (bounded) {
    hit = bounded_search(box, o, d, t0, t1, crossings, settings, &lo, &hi);
    t = t1;  // no linear search
  }
  for (int i = 1; i <= settings.max_steps + 6 && !hit && t < t1; ++i) {
    double advance = step;
    if (settings.sampling == Sampling::Threshold) {
      const double watched = std::abs(hollow ? s.f : value(box, s));
      if (s.valid)
        advance = watched < settings.threshold_voxels * implicit_spacing(box)
                      ? step * settings.fine_factor
                      : std::min(watched, step);
    } else if (settings.sampling == Sampling::Jacobian && !box.moves_nothing) {
      advance = jacobian_step(box, o + t * d, d, step);
    }
    if (skip) advance = std::max(advance, skip_distance(box, s));
    double next_crossing = kInfinity;
    for (double tc : crossings)
      next_crossing = tc > t ? std::min(next_crossing, tc) : next_crossing;
    const double target = std::min(t + advance, t1);
    const bool at_face = next_crossing < target;
    const double tn = at_face ? next_crossing : target;
    const Vec3 pn = o + tn * d;
    const Sample sn = at(tn, was_in_box);
    if (hollow) {
      // A thin shell: any change of sign of f, kept where it lies outside the cut (5.1.1).
      if (s.valid && sn.valid && (s.f > 0.0) != (sn.f > 0.0)) {
        const bool inside = s.f > 0.0;
        double l = t, r = tn;
        for (int k = 0; k < settings.refine_steps; ++k) {
          double mid = 0.5 * (l + r);
          ((at(mid, true).f > 0.0) == inside ? l : r) = mid;
        }
        if (alpha_at(box, o + 0.5 * (l + r) * d) <= 0.0) {
          hit = true;
          front = !inside;
          lo = l;
          hi = r;
        }
      }
      if (!hit && at_face && s.valid && sn.valid && s.f <= 0.0 && sn.f > -seam && sn.a <= 0.0) {
        hit = true;
        lo = hi = tn;
      }
      // Entering the box's preimage where the deformation is the identity, a first sample inside
      // the solid: the ray entered it since the last sample (the shader's rule).
      const bool identity = box.moves_nothing || deformation_at(box, pn).head<3>().norm() < seam;
      if (!hit && !s.valid && sn.valid && sn.f > 0.0 && sn.a <= 0.0 && identity) {
        double l = t, r = tn;
        for (int k = 0; k < settings.refine_steps; ++k) {
          double mid = 0.5 * (l + r);
          (at(mid, true).f > 0.0 ? r : l) = mid;
        }
        hit = true;
        front = true;
        lo = l;
        hi = r;
      }
    } else {
      const double v = value(box, sn);
      if (v > 0.0) {
        hit = true;
        lo = t;
        hi = tn;
      } else if (at_face && v > -seam) {
        // At a face the implicit surface may lie up to about a voxel inside the mesh that the
        // raster pass draws beyond the face: within `seam` of it counts as the hit, so no crack
        // opens between the passes.
        hit = true;
        lo = hi = tn;
      } else if (box.has_cut && s.valid && sn.valid && s.a > 0.0 && sn.a <= 0.0 &&
                 surface(box, s.f) > 0.0) {
        // The step crossed a cut face from the object's removed part: the object may go on for
        // less than a step past the face (near a cap's outline, where the face meets the
        // surface). Its crossing, found by bisection on A, and just past it (the shader's rule).
        double l = t, r = tn;
        for (int k = 0; k < settings.refine_steps; ++k) {
          double mid = 0.5 * (l + r);
          (at(mid, true).a > 0.0 ? l : r) = mid;
        }
        if (surface(box, at(r, true).f) > 0.0) {
          hit = true;
          lo = l;
          hi = r;
        }
      }
    }
    if (!hollow) {
      // A grazing ray: the value peaks at the last sample, between two lower ones, and the
      // parabola through the three comes near the surface; the first such bracket is searched
      // after the march (the shader's rule).
      const double v_last = value(box, s), v = value(box, sn);
      if (!hit && !grazed && s.valid && sn.valid && v_last > v && v_last > v_before &&
          parabola_peak(t_before, t, tn, v_before, v_last, v) > -kGrazeMargin * (tn - t_before)) {
        grazed = true;
        graze_l = t_before;
        graze_r = tn;
      }
      t_before = t;
      v_before = s.valid ? v_last : -1e30;
    }
    t = tn;
    s = sn;
    was_in_box = box.box.contains_local(pn);
  }
  // The first grazing bracket in front of the hit (or with no hit): golden-section search for
  // the value's peak in it, and the hit there where the peak is inside or within
  // kGrazeHitVoxels of the surface.
  if (!hollow && !bounded && grazed && (!hit || graze_r <= lo)) {
    double l = graze_l, r = graze_r;
    double x1 = r - kGolden * (r - l), x2 = l + kGolden * (r - l);
    double f1 = value(box, at(x1, true)), f2 = value(box, at(x2, true));
    // A depth cube's |f| is no distance: there only a peak inside is the hit.
    const double near_enough = box.uses_depth_cube ? 0.0 : -kGrazeHitVoxels * implicit_spacing(box);
    for (int k = 0; k < kGrazeSteps && std::max(f1, f2) <= near_enough; ++k) {
      if (f1 > f2) {
        r = x2;
        x2 = x1;
        f2 = f1;
        x1 = r - kGolden * (r - l);
        f1 = value(box, at(x1, true));
      } else {
        l = x1;
        x1 = x2;
        f1 = f2;
        x2 = l + kGolden * (r - l);
        f2 = value(box, at(x2, true));
      }
    }
    if (std::max(f1, f2) > near_enough) {
      hit = true;
      lo = graze_l;
      hi = f1 > near_enough ? x1 : x2;
    }
  }
  if (!hit) return std::nullopt;
  if (!hollow)  // binary refinement between the last sample outside and the first inside
    for (int i = 0; i < settings.refine_steps; ++i) {
      double mid = 0.5 * (lo + hi);
      (value(box, at(mid, true)) > 0.0 ? hi : lo) = mid;
    }
  RayHit out;
  out.t = 0.5 * (lo + hi);
  out.point = o + out.t * d;
  Vec3 normal = deformed_normal(box, out.point);
  if (hollow && !front) {
    normal = -normal;
    out.kind = HitKind::Inside;
  } else if (box.has_cut && !hollow) {
    // Eq. 6: on the object's surface the normal of eq. 5, on the cut face grad A.
    const Sample sh = at(out.t, true);
    if (surface(box, sh.f) > -sh.a) {
      normal = alpha_gradient(box, out.point);
      out.kind = HitKind::CutFace;
    } else if (box.cut_mode == CutMode::ThickShell && sh.f > 0.5 * box.shell_thickness) {
      normal = -normal;
      out.kind = HitKind::Inside;
    }
  }
  out.normal = unit_or(normal, -d);
  return out;
}

Image reference_render(const Mesh& mesh, const std::vector<BoxTextures>& boxes,
                       const Camera& camera, int width, int height,
                       const RenderSettings& settings) {
  check_image_size("reference_render", width, height);
  Image image(width, height);
  const TriangleBvh bvh(mesh);
  const auto normals = vertex_normals(mesh);
  const bool any_cut =
      std::any_of(boxes.begin(), boxes.end(), [](const BoxTextures& b) { return b.has_cut; });
  parallel_for(height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      Ray ray = camera.pixel_ray(x, y, width, height);
      double best_t = kInfinity;
      Vec3 normal = -ray.direction;
      HitKind kind = HitKind::Surface;
      // The mesh where it lies outside every box (raster pass).
      auto outside_boxes = [&](double t) {
        Vec3 p = ray.origin + t * ray.direction;
        return std::none_of(boxes.begin(), boxes.end(),
                            [&](const BoxTextures& b) { return b.box.contains(p); });
      };
      if (auto h =
              bvh.nearest_hit(ray.origin, ray.direction, ray.t_min, ray.t_max, outside_boxes)) {
        best_t = h->hit.t;
        Vec3 n = (1.0 - h->hit.u - h->hit.v) * normals.row(mesh.F(h->triangle, 0)).transpose() +
                 h->hit.u * normals.row(mesh.F(h->triangle, 1)).transpose() +
                 h->hit.v * normals.row(mesh.F(h->triangle, 2)).transpose();
        if (n.norm() == 0.0) {
          const Vec3 a = mesh.vertex(h->triangle, 0);
          n = (mesh.vertex(h->triangle, 1) - a).cross(mesh.vertex(h->triangle, 2) - a);
        }
        if (n.norm() > 0.0) normal = n.normalized();
        // With a cut, a back face (the mesh is oriented outwards) is the inside of the shell.
        const Vec3 a = mesh.vertex(h->triangle, 0);
        const Vec3 geometric =
            (mesh.vertex(h->triangle, 1) - a).cross(mesh.vertex(h->triangle, 2) - a);
        if (any_cut && geometric.dot(ray.direction) > 0.0) {
          kind = HitKind::Inside;
          normal = -normal;
        }
      }
      // The boxes (ray-cast pass); the local frame is rigid, so t is the same.
      for (const BoxTextures& b : boxes) {
        Vec3 o = b.box.to_local(ray.origin), d = b.box.direction_to_local(ray.direction);
        auto [t0, t1] = texture_range(b, o, d, ray.t_min, ray.t_max);
        if (auto h = ray_cast_box(b, o, d, t0, t1, settings); h && h->t < best_t) {
          best_t = h->t;
          normal = b.box.direction_to_object(h->normal);
          kind = h->kind;
        }
      }
      if (best_t == kInfinity) {
        put_colour(image, x, y, settings.background);
        continue;
      }
      Vec3 p = ray.origin + best_t * ray.direction;
      image.depth[static_cast<size_t>(y) * width + x] = static_cast<float>(camera.depth_of(p));
      put_colour(image, x, y, shade(albedo_of(settings, kind), normal, ray.direction));
    }
  });
  return image;
}

Mesh ground_truth_mesh(const Mesh& mesh, const Box& box,
                       const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& forward_local,
                       double max_edge, int split_axis, double split_at) {
  if (!(max_edge > 0.0) || !std::isfinite(max_edge))
    throw Error("ground_truth_mesh: max_edge = " + std::to_string(max_edge) +
                ": must be a finite number > 0");
  MeshBuilder out;
  // Original vertices first, so triangles clear of the box keep their indices.
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    out.vertices.push_back(mesh.V.row(v).transpose());
  const Vec3 half = box.half_extents;
  // Pieces on either side of the split plane: F as the limit from that side.
  const double nudge = 1e-9 * half.maxCoeff();
  auto deform_below = [&](Vec3 q) {
    q[split_axis] = std::min(q[split_axis], split_at - nudge);
    return box.to_object(forward_local(q));
  };
  auto deform_above = [&](Vec3 q) {
    if (split_axis >= 0) q[split_axis] = std::max(q[split_axis], split_at + nudge);
    return box.to_object(forward_local(q));
  };
  auto keep = [&](const Vec3& q) { return box.to_object(q); };
  struct Piece {
    Polygon polygon;
    bool inside;
    bool below = false;  // on the negative side of the split plane
  };
  std::vector<Piece> pieces;
  Polygon inner, outer;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    std::array<Vec3, 3> q;
    for (int c = 0; c < 3; ++c) q[c] = box.to_local(mesh.vertex(static_cast<int>(f), c));
    if (beyond_one_face(q, half)) {
      out.faces.push_back(mesh.F.row(f).transpose());
      continue;
    }
    // Split by the six face planes; only the part still inside needs the later planes.
    pieces.assign(1, Piece{Polygon(q.begin(), q.end()), true});
    for (int a = 0; a < 3; ++a)
      for (double side : {1.0, -1.0}) {
        size_t n = pieces.size();
        for (size_t k = 0; k < n; ++k) {
          if (!pieces[k].inside) continue;
          split_polygon(pieces[k].polygon, a, side, half[a], inner, outer);
          pieces[k].polygon = inner;
          if (!outer.empty()) pieces.push_back(Piece{outer, false});
        }
      }
    if (split_axis >= 0) {
      size_t n = pieces.size();
      for (size_t k = 0; k < n; ++k) {
        if (!pieces[k].inside) continue;
        split_polygon(pieces[k].polygon, split_axis, 1.0, split_at, inner, outer);
        pieces[k].polygon = outer;  // q[split_axis] >= split_at
        if (!inner.empty()) pieces.push_back(Piece{inner, true, true});
      }
      std::erase_if(pieces, [](const Piece& p) { return p.polygon.empty(); });
    }
    for (const Piece& piece : pieces) {
      const Polygon& poly = piece.polygon;
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        if (!piece.inside) {
          out.faces.emplace_back(out.add(keep(poly[0])), out.add(keep(poly[k])),
                                 out.add(keep(poly[k + 1])));
          continue;
        }
        double longest = std::max({(poly[k] - poly[0]).norm(), (poly[k + 1] - poly[k]).norm(),
                                   (poly[0] - poly[k + 1]).norm()});
        int n = std::max(1, static_cast<int>(std::ceil(longest / max_edge)));
        if (piece.below)
          add_subdivided(out, poly[0], poly[k], poly[k + 1], n, deform_below);
        else
          add_subdivided(out, poly[0], poly[k], poly[k + 1], n, deform_above);
      }
    }
  }
  return out.finish();
}

Image rasterize(const Mesh& mesh, const Camera& camera, int width, int height,
                const RenderSettings& settings) {
  check_image_size("rasterize", width, height);
  const Rasterizer raster(mesh, camera, width, height);
  const int faces = static_cast<int>(mesh.F.rows());

  // Rows each face may cover, so each band of rows only visits its own faces.
  std::vector<std::pair<int, int>> rows(faces);
  constexpr int kChunk = 4096;
  parallel_for((faces + kChunk - 1) / kChunk, [&](int chunk) {
    for (int f = chunk * kChunk; f < std::min(faces, (chunk + 1) * kChunk); ++f)
      rows[f] = raster.rows(f);
  });

  std::vector<double> depth(static_cast<size_t>(width) * height, kInfinity);
  std::vector<int> face(depth.size(), -1);
  constexpr int kBandRows = 8;
  parallel_for((height + kBandRows - 1) / kBandRows, [&](int band) {
    int row0 = band * kBandRows, row1 = std::min(height, row0 + kBandRows) - 1;
    for (int f = 0; f < faces; ++f)
      if (rows[f].first <= row1 && rows[f].second >= row0) raster.draw(f, row0, row1, depth, face);
  });

  Image image(width, height);
  parallel_for(height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      size_t i = static_cast<size_t>(y) * width + x;
      if (face[i] < 0) {
        put_colour(image, x, y, settings.background);
        continue;
      }
      const Vec3 a = mesh.vertex(face[i], 0);
      Vec3 n = (mesh.vertex(face[i], 1) - a).cross(mesh.vertex(face[i], 2) - a);
      n = n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero();
      image.depth[i] = static_cast<float>(depth[i]);
      put_colour(image, x, y,
                 shade(settings.colour, n, camera.pixel_ray(x, y, width, height).direction));
    }
  });
  return image;
}

Image exact_removed_render(const Mesh& mesh, const Box& box, const RegionIntervals& intervals,
                           CutMode mode, const Camera& camera, int width, int height,
                           const RenderSettings& settings) {
  check_image_size("exact_removed_render", width, height);
  if (mode == CutMode::ThickShell)
    throw Error("exact_removed_render: thick shells have no exact reference");
  Image image(width, height);
  const TriangleBvh bvh(mesh);
  const auto normals = vertex_normals(mesh);
  parallel_for(height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const Ray ray = camera.pixel_ray(x, y, width, height);
      // The ray's intervals in the region (the local frame is rigid: same t).
      const std::vector<RegionInterval> in =
          intervals(box.to_local(ray.origin), box.direction_to_local(ray.direction));
      auto outside_region = [&](double t) {
        for (const RegionInterval& i : in)
          if (t > i.t0 && t < i.t1) return false;
        return true;
      };
      double best_t = kInfinity;
      Vec3 normal = -ray.direction;
      HitKind kind = HitKind::Surface;
      if (auto h =
              bvh.nearest_hit(ray.origin, ray.direction, ray.t_min, ray.t_max, outside_region)) {
        best_t = h->hit.t;
        Vec3 n = (1.0 - h->hit.u - h->hit.v) * normals.row(mesh.F(h->triangle, 0)).transpose() +
                 h->hit.u * normals.row(mesh.F(h->triangle, 1)).transpose() +
                 h->hit.v * normals.row(mesh.F(h->triangle, 2)).transpose();
        if (n.norm() > 0.0) normal = n.normalized();
        const Vec3 a = mesh.vertex(h->triangle, 0);
        const Vec3 geometric =
            (mesh.vertex(h->triangle, 1) - a).cross(mesh.vertex(h->triangle, 2) - a);
        if (geometric.dot(ray.direction) > 0.0) {
          kind = HitKind::Inside;
          normal = -normal;
        }
      }
      // Solid: the earliest point where the ray leaves the region inside the mesh, if before.
      if (mode == CutMode::Solid)
        for (const RegionInterval& i : in)
          if (i.t0 < i.t1 && i.t1 > ray.t_min && i.t1 < best_t && i.t1 < ray.t_max &&
              std::isfinite(i.t1) && bvh.count_after(ray.origin, ray.direction, i.t1) % 2 == 1) {
            best_t = i.t1;
            kind = HitKind::CutFace;
            normal = -box.direction_to_object(i.exit_normal);
          }
      if (best_t == kInfinity) {
        put_colour(image, x, y, settings.background);
        continue;
      }
      const Vec3 p = ray.origin + best_t * ray.direction;
      image.depth[static_cast<size_t>(y) * width + x] = static_cast<float>(camera.depth_of(p));
      put_colour(image, x, y, shade(albedo_of(settings, kind), normal, ray.direction));
    }
  });
  return image;
}

Image exact_cut_render(const Mesh& mesh, const Box& box, const std::vector<HalfSpace>& region,
                       CutMode mode, const Camera& camera, int width, int height,
                       const RenderSettings& settings) {
  // A convex region: one interval [c0, c1], left through the half-space whose plane ends it.
  auto interval = [&](const Vec3& o, const Vec3& d) {
    double c0 = -kInfinity, c1 = kInfinity;
    int exit_plane = -1;
    for (size_t k = 0; k < region.size() && c0 <= c1; ++k) {
      const double nd = region[k].normal.dot(d), dist = region[k].offset - region[k].normal.dot(o);
      if (nd == 0.0) {
        if (dist < 0.0) c0 = kInfinity;
        continue;
      }
      const double t = dist / nd;
      if (nd > 0.0 && t < c1) {
        c1 = t;
        exit_plane = static_cast<int>(k);
      } else if (nd < 0.0) {
        c0 = std::max(c0, t);
      }
    }
    std::vector<RegionInterval> out;
    if (c0 < c1)
      out.push_back({c0, exit_plane >= 0 ? c1 : kInfinity,
                     exit_plane >= 0 ? region[exit_plane].normal : Vec3::Zero().eval()});
    return out;
  };
  return exact_removed_render(mesh, box, interval, mode, camera, width, height, settings);
}

std::vector<RegionInterval> groove_intervals(int axis, double radius, double width, const Vec3& o,
                                             const Vec3& d) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  // The slab |x_a| <= width / 2.
  double s0 = -kInfinity, s1 = kInfinity;
  Vec3 slab_exit = Vec3::Zero();
  if (d[axis] == 0.0) {
    if (std::abs(o[axis]) > 0.5 * width) return {};
  } else {
    const double ta = (-0.5 * width - o[axis]) / d[axis], tb = (0.5 * width - o[axis]) / d[axis];
    s0 = std::min(ta, tb);
    s1 = std::max(ta, tb);
    slab_exit[axis] = d[axis] > 0.0 ? 1.0 : -1.0;
  }
  // Inside the infinite cylinder r < radius for t in (q0, q1): A t^2 + B t + C < 0.
  const double A = d[u] * d[u] + d[v] * d[v], B = 2.0 * (o[u] * d[u] + o[v] * d[v]),
               C = o[u] * o[u] + o[v] * o[v] - radius * radius;
  const double disc = B * B - 4.0 * A * C;
  if (A == 0.0 || disc <= 0.0) {
    if (A == 0.0 && C < 0.0) return {};
    return {{s0, s1, slab_exit}};
  }
  const double sq = std::sqrt(disc);
  const double q = -0.5 * (B + (B >= 0.0 ? sq : -sq));
  const double q0 = std::min(q / A, C / q), q1 = std::max(q / A, C / q);
  // The region's outward normal where the ray enters the cylinder: towards the axis.
  Vec3 p = o + q0 * d;
  p[axis] = 0.0;
  const Vec3 inward = -p / std::max(p.norm(), 1e-300);
  std::vector<RegionInterval> out;
  if (std::min(s1, q0) > s0) {
    if (q0 < s1)
      out.push_back({s0, q0, inward});
    else
      out.push_back({s0, s1, slab_exit});
  }
  if (std::max(s0, q1) < s1) out.push_back({std::max(s0, q1), s1, slab_exit});
  return out;
}

}  // namespace raywarp
