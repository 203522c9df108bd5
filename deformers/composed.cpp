#include "deformers/composed.h"

#include "base/error.h"
#include "deformers/detail.h"

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

// A list ending in detail entries (composed.h): forward the composition, inverse the sum.
class DetailSum final : public AddedDetail {
 public:
  DetailSum(std::vector<std::shared_ptr<const Deformer>> parts, size_t rest)
      : parts_(parts), all_(std::move(parts)), rest_(rest) {}

  std::string describe() const override {
    std::string s;
    for (size_t i = 0; i < parts_.size(); ++i) {
      if (i < rest_)
        s += (i ? ", then " : "") + parts_[i]->describe();
      else
        s += (i ? ", plus added " : "added ") + parts_[i]->describe();
    }
    return s;
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override { return all_.forward(p); }
  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override { return all_.jacobian(p); }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    Eigen::Vector3d p = p_def;
    for (size_t i = rest_; i-- > 0;) p = parts_[i]->inverse(p);
    for (size_t i = rest_; i < parts_.size(); ++i) p += parts_[i]->inverse(p_def) - p_def;
    return clamp_finite(p);
  }

  Eigen::Vector3d exact_inverse(const Eigen::Vector3d& p_def) const override {
    return all_.inverse(p_def);
  }

  std::array<bool, 6> identity_faces() const override { return all_.identity_faces(); }

  size_t rest_count() const override { return rest_; }
  size_t detail_count() const override { return parts_.size() - rest_; }

 private:
  std::vector<std::shared_ptr<const Deformer>> parts_;
  Composed all_;
  size_t rest_;
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
  // Detail entries are added at the end of the list, after every other deformer.
  size_t rest = parts.size();
  while (rest > 0 && is_detail(*parts[rest - 1])) --rest;
  for (size_t i = 0; i < rest; ++i)
    if (is_detail(*parts[i]))
      throw Error("[" + std::to_string(i) + "] (" + parts[i]->describe() +
                  "): a detail is added to the result of the deformers before it; list it after "
                  "every other deformer (here after [" +
                  std::to_string(rest - 1) + "], " + parts[rest - 1]->describe() + ")");
  if (rest < parts.size()) return std::make_unique<DetailSum>(std::move(parts), rest);
  return std::make_unique<Composed>(std::move(parts));
}

}  // namespace raywarp
