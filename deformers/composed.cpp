#include "deformers/composed.h"

#include "base/error.h"

namespace raywarp {

namespace {

class Composed final : public Deformer {
 public:
  explicit Composed(std::vector<std::shared_ptr<const Deformer>> parts)
      : parts_(std::move(parts)) {}

  std::string describe() const override {
    std::string s;
    for (size_t i = 0; i < parts_.size(); ++i) s += (i ? ", then " : "") + parts_[i]->describe();
    return s;
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    Eigen::Vector3d q = p;
    for (const auto& f : parts_) q = f->forward(q);
    return q;
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
    Eigen::Vector3d q = p;
    for (const auto& f : parts_) {
      j = f->jacobian(q) * j;
      q = f->forward(q);
    }
    return j;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    Eigen::Vector3d p = p_def;
    for (auto it = parts_.rbegin(); it != parts_.rend(); ++it) p = (*it)->inverse(p);
    return p;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> all;
    all.fill(true);
    for (const auto& f : parts_) {
      const auto faces = f->identity_faces();
      for (int i = 0; i < 6; ++i) all[i] = all[i] && faces[i];
    }
    return all;
  }

 private:
  std::vector<std::shared_ptr<const Deformer>> parts_;
};

}  // namespace

std::unique_ptr<Deformer> make_composed(std::vector<std::shared_ptr<const Deformer>> parts) {
  if (parts.empty()) throw Error("a composition needs at least one deformer");
  for (size_t i = 0; i < parts.size(); ++i) {
    if (!parts[i]) throw Error("[" + std::to_string(i) + "]: no deformer");
    if (parts[i]->has_cut() || parts[i]->moves_nothing())
      throw Error("[" + std::to_string(i) + "] (" + parts[i]->describe() +
                  "): cuts cannot be composed with other deformers; give a cut its own box");
  }
  return std::make_unique<Composed>(std::move(parts));
}

}  // namespace raywarp
