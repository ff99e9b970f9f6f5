// expect: must define `static constexpr std::size_t kMaxModels`
// An Estimator without kMaxModels: the error must name kMaxModels, not list all six members.
#include <array>
#include <cstddef>

#include <diachron/core/static_vector.hpp>
#include <diachron/robust/ransac.hpp>

struct NoMaxModels {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, 1>;
  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return datum - model; }
};

int main() { return diachron::Ransac<NoMaxModels>().options().seed == 0 ? 0 : 1; }
