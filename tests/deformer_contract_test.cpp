// Named after no one source: a contract every type of the registry keeps.
// The deformer contract suite: every registered type (deformers/registry.h), with every one of
// its examples, built through the registry exactly as a scene builds it (read_deformer, then
// make_deformer), must keep the contract of deformers/deformer.h:
//   RoundTrip          F(inverse(F(p))) = F(p) off the cut and off folds, and inverse(F(p)) = p
//                      there too (every registered example is injective on that set: see the
//                      test)
//   Jacobian           the analytic dF/dp against central differences, where F is smooth
//   IdentityFaces      F = identity on every face identity_faces() flags
//   Finite             forward, jacobian, inverse (and alpha) finite inside, outside and far away;
//                      inverse finite for every finite input
//   ErrorsNamed        every declared parameter of the wrong kind, an unknown key and every
//                      missing required parameter refused by read_deformer, naming the field
//   Describes          describe() and describe_spec()
//   Flags              moves_nothing() and has_cut() agree with what F and the registry say
// A newly registered type, or example, is tested with no change here. Instances are named
// <type>_<example index>: twist_0, peel_1. Each test prints its worst figures as a
// `[figures] contract ...` line.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "base/box.h"
#include "base/error.h"
#include "base/json_reader.h"
#include "deformers/deformer.h"
#include "deformers/registry.h"

namespace raywarp {
namespace {

using json = nlohmann::json;

// The box every registered example is written for.
const Eigen::Vector3d kHalf(1.0, 1.5, 1.0);

struct Instance {
  const DeformerType* type = nullptr;
  size_t example = 0;
  std::string name() const { return type->name + "_" + std::to_string(example); }
};

std::vector<Instance> all_instances() {
  std::vector<Instance> out;
  for (const DeformerType& t : deformer_types())
    for (size_t i = 0; i < t.examples.size(); ++i) out.push_back({&t, i});
  return out;
}

Box contract_box() {
  Box box;
  box.half_extents = kHalf;
  return box;
}

// {"type": name, ...example}.
json scene_json(const Instance& in) {
  json j = in.type->examples[in.example];
  j["type"] = in.type->name;
  return j;
}

// Read as from a scene file in the source folder, so that file parameters resolve against it.
DeformerSpec read(const json& j) {
  return read_deformer(JsonReader(std::string(RAYWARP_SOURCE_DIR) + "/contract.json"), j,
                       "deformer", contract_box());
}

// The message read_deformer refuses `j` with, or "(accepted)".
std::string refusal(const json& j) {
  try {
    read(j);
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937& rng, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(kHalf);
}

class DeformerContract : public ::testing::TestWithParam<Instance> {
 protected:
  void SetUp() override {
    type_ = GetParam().type;
    spec_ = read(scene_json(GetParam()));
    // A type built over the mesh part (the simulation) gets a cylinder of radius 0.6 along y,
    // through the -y and +y faces.
    SimulationInput part;
    part.signed_distance = [](const Eigen::Vector3d& q) {
      return 0.6 - Eigen::Vector2d(q.x(), q.z()).norm();
    };
    // A type fitted to vertex pairs (from_mesh) gets the cylinder's surface turned about y by up
    // to 0.35 rad at mid-height, not at all at the -y and +y faces it crosses.
    for (int i = 0; i < 40; ++i)
      for (int j = 0; j < 24; ++j) {
        const double y = -kHalf.y() + 2.0 * kHalf.y() * i / 39.0;
        const double a = 2.0 * M_PI * j / 24.0;
        const double turn = 0.35 * std::sin(M_PI * (y + kHalf.y()) / (2.0 * kHalf.y()));
        part.sources.emplace_back(0.6 * std::cos(a), y, 0.6 * std::sin(a));
        part.targets.emplace_back(0.6 * std::cos(a + turn), y, 0.6 * std::sin(a + turn));
      }
    deformer_ = make_deformer(spec_, contract_box().half_extents, part);
    ASSERT_TRUE(deformer_);
  }
  bool in_cut(const Eigen::Vector3d& p_def) const {
    return deformer_->has_cut() && deformer_->alpha(p_def) > 0.0;
  }
  std::string where() const { return GetParam().name() + " (" + deformer_->describe() + ")"; }

  const DeformerType* type_ = nullptr;
  DeformerSpec spec_;
  std::unique_ptr<Deformer> deformer_;
  const double h_norm_ = kHalf.norm();
};

// (a) For p in the box with det J(p) > 0 and p' = F(p) outside the cut region (alpha(p') <= 0):
// F(inverse(p')) = p' to 1e-9 |h|, which is the contract of deformer.h for every type.
// inverse(F(p)) = p is asserted on the same set: deformer.h asks it only where F is injective,
// and each header narrows it (bend: where 1 - k q_b > 0 and the rigid continuations do not reach
// the image; peel: in the box with v < R off the cut plane, unless F(p) lies in a folded flap's
// image; incision and the Simple Deform modes: everywhere; control points: where F is a
// bijection). Every registered example satisfies those conditions on that set (no example folds
// in the box: det J > 0 is checked point by point; no bend example goes past 360 degrees; the
// peel examples have R > t), so this is asserted for all of them; a new example that folds or
// overlaps itself would have to narrow the set.
TEST_P(DeformerContract, RoundTrip) {
  std::mt19937 rng(1);
  const double tol = 1e-9 * h_norm_;
  double worst_fif = 0.0, worst_ifp = 0.0;
  int checked = 0, in_cut_count = 0, folded = 0;
  for (int n = 0; n < 4000; ++n) {
    const Eigen::Vector3d p = random_point(rng);
    const Eigen::Vector3d p_def = deformer_->forward(p);
    if (in_cut(p_def)) {
      ++in_cut_count;
      continue;
    }
    if (!(deformer_->jacobian(p).determinant() > 0.0)) {
      ++folded;
      continue;
    }
    ++checked;
    const Eigen::Vector3d back = deformer_->inverse(p_def);
    const double fif = (deformer_->forward(back) - p_def).norm();
    const double ifp = (back - p).norm();
    worst_fif = std::max(worst_fif, fif);
    worst_ifp = std::max(worst_ifp, ifp);
    EXPECT_LE(fif, tol) << where() << " F(inverse(F(p))) at p = " << p.transpose();
    EXPECT_LE(ifp, tol) << where() << " inverse(F(p)) at p = " << p.transpose();
  }
  EXPECT_GT(checked, 2000) << where();
  std::printf(
      "[figures] contract round trip %s: |F(inv(p')) - p'| <= %.3g, |inv(F(p)) - p| <= %.3g "
      "(|h| units: %.3g, %.3g) over %d points; %d in the cut, %d folded\n",
      GetParam().name().c_str(), worst_fif, worst_ifp, worst_fif / h_norm_, worst_ifp / h_norm_,
      checked, in_cut_count, folded);
}

// (b) Central differences with step d = 1e-6 |h| at random points of the box: accepted where
// |J - J_fd| <= 1e-5 (1 + |J|) (Frobenius norms). Where F is not smooth within the step (a kink
// at a limit plane, a peel's hinge, a cut's surface) the one-sided differences disagree: such a
// point is skipped when |J_+ - J_-| > 1e-4 (1 + |J|) (a smooth F gives |J_+ - J_-| ~ d |F''|,
// ~1e-5 for the strongest example), and at least 90 % of the points must be checked.
TEST_P(DeformerContract, Jacobian) {
  std::mt19937 rng(2);
  const double d = 1e-6 * h_norm_;
  const int samples = 2000;
  int checked = 0;
  double worst = 0.0;
  for (int n = 0; n < samples; ++n) {
    const Eigen::Vector3d p = random_point(rng);
    const Eigen::Vector3d f0 = deformer_->forward(p);
    Eigen::Matrix3d central, plus, minus;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
      const Eigen::Vector3d fp = deformer_->forward(p + step), fm = deformer_->forward(p - step);
      central.col(j) = (fp - fm) / (2.0 * d);
      plus.col(j) = (fp - f0) / d;
      minus.col(j) = (f0 - fm) / d;
    }
    const Eigen::Matrix3d J = deformer_->jacobian(p);
    const double scale = 1.0 + J.norm();
    if ((plus - minus).norm() > 1e-4 * scale) continue;  // not smooth within the step
    ++checked;
    const double err = (J - central).norm() / scale;
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-5) << where() << " at " << p.transpose() << "\nanalytic\n"
                         << J << "\ncentral\n"
                         << central;
  }
  EXPECT_GE(checked, 0.9 * samples) << where() << ": too many points where F is not smooth";
  std::printf(
      "[figures] contract jacobian %s: |J - J_fd| / (1 + |J|) <= %.3g over %d of %d points\n",
      GetParam().name().c_str(), worst, checked, samples);
}

// (c) F(p) = p to 1e-12 |h| at random points of every face identity_faces() flags. The converse
// (a face not flagged moves somewhere) is not part of the contract: a face may move only in part,
// or identity_faces() may be conservative. It is reported, not asserted.
TEST_P(DeformerContract, IdentityFaces) {
  std::mt19937 rng(3);
  const std::array<bool, 6> faces = deformer_->identity_faces();
  double worst = 0.0;
  std::string flagged, unmoved;
  for (int f = 0; f < 6; ++f) {
    const int axis = f / 2;
    const double side = f % 2 ? 1.0 : -1.0;
    double moved = 0.0;
    for (int n = 0; n < 500; ++n) {
      Eigen::Vector3d p = random_point(rng);
      p[axis] = side * kHalf[axis];
      const double m = (deformer_->forward(p) - p).norm();
      moved = std::max(moved, m);
      if (faces[f]) {
        EXPECT_LE(m, 1e-12 * h_norm_) << where() << " face " << f << " at " << p.transpose();
      }
    }
    const std::string name = face_name(Face{static_cast<Axis>(axis), f % 2 ? 1 : -1});
    if (faces[f]) {
      worst = std::max(worst, moved);
      flagged += " " + name;
    } else if (moved <= 1e-9 * h_norm_) {
      unmoved += " " + name;
    }
  }
  std::printf(
      "[figures] contract identity faces %s: flagged%s, worst |F(p) - p| %.3g; not flagged but "
      "unmoved:%s\n",
      GetParam().name().c_str(), flagged.empty() ? " none" : flagged.c_str(), worst,
      unmoved.empty() ? " none" : unmoved.c_str());
}

bool finite(double x) { return std::isfinite(x); }

// (d) Finite results at random points inside the box, around it (3 h), far away (1e6 |h| and
// 1e15 |h|); and the inverse, which deformer.h promises finite for every finite input, at inputs
// up to +-DBL_MAX. The forward map, its Jacobian and alpha at +-DBL_MAX are promised only by some
// headers (taper, stretch, peel, incision, control points; not twist or bend, whose rotation of
// a coordinate near DBL_MAX overflows): they are reported, not asserted.
TEST_P(DeformerContract, Finite) {
  std::mt19937 rng(4);
  const double scales[] = {1.0, 3.0, 1e6, 1e15};
  for (double scale : scales)
    for (int n = 0; n < 500; ++n) {
      // The far points lie on a sphere of radius `scale` |h|, in every direction.
      Eigen::Vector3d p = random_point(rng, scale);
      if (scale > 3.0) p = p.normalized() * scale * h_norm_;
      EXPECT_TRUE(deformer_->forward(p).allFinite()) << where() << " forward at " << p.transpose();
      EXPECT_TRUE(deformer_->jacobian(p).allFinite())
          << where() << " jacobian at " << p.transpose();
      EXPECT_TRUE(deformer_->inverse(p).allFinite()) << where() << " inverse at " << p.transpose();
      if (deformer_->has_cut()) {
        EXPECT_TRUE(finite(deformer_->alpha(p))) << where() << " alpha at " << p.transpose();
      }
    }
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  std::vector<Eigen::Vector3d> extremes = {
      Eigen::Vector3d(big, -big, big),    Eigen::Vector3d(-big, big, -big),
      Eigen::Vector3d(big, big, big),     Eigen::Vector3d(-big, -big, -big),
      Eigen::Vector3d(big, 0.0, 0.0),     Eigen::Vector3d(0.0, -big, 0.0),
      Eigen::Vector3d(0.0, 0.0, big),     Eigen::Vector3d(0.5 * big, -0.25 * big, 0.1),
      Eigen::Vector3d(tiny, -0.0, -tiny), Eigen::Vector3d(1e300, -1e-300, 1e150),
      Eigen::Vector3d(0.1, 1e308, -0.2)};
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 307);
  for (int n = 0; n < 200; ++n) {
    Eigen::Vector3d p;
    for (int i = 0; i < 3; ++i) p[i] = unit(rng) * std::pow(10.0, exponent(rng));
    extremes.push_back(p);
  }
  int unpromised = 0, nan = 0;
  for (const Eigen::Vector3d& p : extremes) {
    EXPECT_TRUE(deformer_->inverse(p).allFinite()) << where() << " inverse at " << p.transpose();
    const Eigen::Vector3d f = deformer_->forward(p);
    const Eigen::Matrix3d J = deformer_->jacobian(p);
    const double a = deformer_->has_cut() ? deformer_->alpha(p) : 0.0;
    unpromised += f.allFinite() && J.allFinite() && finite(a) ? 0 : 1;
    nan += f.hasNaN() || J.hasNaN() || std::isnan(a) ? 1 : 0;
  }
  std::printf(
      "[figures] contract finite %s: inverse finite at all %zu extreme inputs; forward, jacobian "
      "or alpha not finite at %d of them, NaN at %d (not asserted)\n",
      GetParam().name().c_str(), extremes.size(), unpromised, nan);
}

// A JSON value of the wrong kind for a parameter of kind `kind`, each one the reader must refuse.
std::vector<json> wrong_values(ParamKind kind) {
  switch (kind) {
    case ParamKind::Number:
      return {"w", true, json::array({1}), nullptr};
    case ParamKind::Axis:
      return {"w", 1, "X", json::array({"x"})};
    case ParamKind::Face:
      return {"w", "y", "+w", 1};
    case ParamKind::Fractions:
      return {"w", 0.5, json::array({0, 1}), json::array({0, "a", 1})};
    case ParamKind::Faces:
      return {"w", json::array({"w"}), "+y"};
    case ParamKind::Points:
      return {"w", json::array(), json::object({{"from", {0, 0, 0}}})};
    case ParamKind::Group:
      return {"w", 1, json::array()};
    case ParamKind::Choice:
      return {"w", 1, json::array({"grid"})};
    case ParamKind::Direction:
      return {"w", 0.5, json::array({0, 1}), json::array({0, "a", 1})};
    case ParamKind::Drags:
      return {"w", 1, json::object({{"path", json::array()}})};
    case ParamKind::File:
      return {"no_such_file.ply", 1, "", json::array({"a.ply"})};
  }
  return {};
}

// (e) Every declared parameter (the children of a Group too) given a value of the wrong kind is
// refused naming "deformer.<key>" and the value; an unknown key is refused naming it; each
// required parameter left out is refused naming it.
TEST_P(DeformerContract, ErrorsNamed) {
  const json base = scene_json(GetParam());
  int refusals = 0;
  auto expect_refused = [&](const json& j, const std::string& field, const std::string& value) {
    const std::string message = refusal(j);
    ++refusals;
    EXPECT_NE(message.find("contract.json: "), std::string::npos) << where() << ": " << message;
    EXPECT_NE(message.find(field), std::string::npos)
        << where() << ": " << j.dump() << " refused without naming " << field << ": " << message;
    EXPECT_NE(message.find(value), std::string::npos)
        << where() << ": " << j.dump() << " refused without the value " << value << ": " << message;
  };
  // The wrong kinds and the missing ones, for `params` under `prefix` in the object at `path`
  // of the document `doc`.
  std::function<void(const json&, const json::json_pointer&, const std::string&,
                     const std::vector<ParamDecl>&)>
      check_params = [&](const json& doc, const json::json_pointer& path, const std::string& prefix,
                         const std::vector<ParamDecl>& params) {
        for (const ParamDecl& p : params) {
          const std::string field = prefix + "." + p.key;
          for (const json& bad : wrong_values(p.kind)) {
            json j = doc;
            j[path / p.key] = bad;
            // A wrong element of a list is named by its index, e.g. deformer.sub_min[1].
            const bool element_wrong =
                (p.kind == ParamKind::Fractions || p.kind == ParamKind::Direction) &&
                bad.is_array() && bad.size() == 3;
            const bool faces_element = p.kind == ParamKind::Faces && bad.is_array();
            if (element_wrong)
              expect_refused(j, field + "[1]", "\"a\"");
            else if (faces_element)
              expect_refused(j, field + "[0]", "\"w\"");
            else
              expect_refused(j, field, show(bad));
          }
          if (p.required && doc.contains(path / p.key)) {
            json j = doc;
            j[path].erase(p.key);
            const std::string message = refusal(j);
            EXPECT_NE(message.find(field + ": missing"), std::string::npos)
                << where() << ": without " << field << ": " << message;
            ++refusals;
          }
          if (p.kind == ParamKind::Group) {
            json j = doc;
            if (!j.contains(path / p.key)) j[path / p.key] = json::parse(p.group_hint);
            ASSERT_EQ(refusal(j), "(accepted)") << where() << ": " << j.dump();
            check_params(j, path / p.key, field, p.children);
            // An unknown key inside the group.
            j[path / p.key]["no_such_key"] = 1;
            expect_refused(j, field + ".no_such_key", "unknown field");
          }
        }
      };
  check_params(base, json::json_pointer(), "deformer", type_->params);
  // An unknown key at the top.
  json unknown = base;
  unknown["no_such_key"] = 1;
  expect_refused(unknown, "deformer.no_such_key", "unknown field");
  // Every declared key is accepted with the example's value (the base is accepted at all).
  EXPECT_EQ(refusal(base), "(accepted)") << where();
  std::printf("[figures] contract errors %s: %d refusals checked\n", GetParam().name().c_str(),
              refusals);
}

void collect_keys(const std::vector<ParamDecl>& params, std::vector<std::string>& out) {
  for (const ParamDecl& p : params) {
    out.push_back(p.key);
    if (p.kind == ParamKind::Group) collect_keys(p.children, out);
  }
}

// (f) describe() is not empty; describe_spec() names the type and every declared key.
TEST_P(DeformerContract, Describes) {
  EXPECT_FALSE(deformer_->describe().empty()) << GetParam().name();
  const std::string text = describe_spec(spec_);
  EXPECT_EQ(text.rfind(type_->name + ": ", 0), 0u) << text;
  std::vector<std::string> keys;
  collect_keys(type_->params, keys);
  for (const std::string& key : keys) {
    const size_t at = text.find(key + " ");
    EXPECT_NE(at, std::string::npos) << GetParam().name() << ": " << text << " lacks " << key;
  }
  // The deformer is the same whatever the example's key order: the cache key is a function of
  // the spec.
  EXPECT_EQ(deformer_key(spec_), deformer_key(read(scene_json(GetParam()))));
}

// (g) moves_nothing() holds exactly when F is the identity (checked at random points inside and
// around the box, with its Jacobian and inverse); has_cut() is the registry's `cuts`.
TEST_P(DeformerContract, Flags) {
  EXPECT_EQ(deformer_->has_cut(), type_->cuts) << where();
  EXPECT_EQ(is_cut(spec_), type_->cuts) << where();
  std::mt19937 rng(5);
  double moved = 0.0, jacobian_off = 0.0, inverse_moved = 0.0;
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d p = random_point(rng, n % 2 ? 3.0 : 1.0);
    moved = std::max(moved, (deformer_->forward(p) - p).norm());
    jacobian_off =
        std::max(jacobian_off, (deformer_->jacobian(p) - Eigen::Matrix3d::Identity()).norm());
    inverse_moved = std::max(inverse_moved, (deformer_->inverse(p) - p).norm());
  }
  if (deformer_->moves_nothing()) {
    EXPECT_EQ(moved, 0.0) << where();
    EXPECT_EQ(jacobian_off, 0.0) << where();
    EXPECT_EQ(inverse_moved, 0.0) << where();
    for (bool f : deformer_->identity_faces()) EXPECT_TRUE(f) << where();
  } else {
    EXPECT_GT(moved, 1e-6 * h_norm_) << where() << ": moves nothing but does not say so";
  }
  std::printf("[figures] contract flags %s: moves_nothing %d, has_cut %d, largest move %.3g\n",
              GetParam().name().c_str(), deformer_->moves_nothing(), deformer_->has_cut(), moved);
}

INSTANTIATE_TEST_SUITE_P(Registry, DeformerContract, ::testing::ValuesIn(all_instances()),
                         [](const ::testing::TestParamInfo<Instance>& info) {
                           return info.param.name();
                         });

// The suite covers the registry: every type has at least one example.
TEST(DeformerContractCoverage, EveryTypeHasAnExample) {
  for (const DeformerType& t : deformer_types()) EXPECT_FALSE(t.examples.empty()) << t.name;
}

}  // namespace
}  // namespace raywarp
