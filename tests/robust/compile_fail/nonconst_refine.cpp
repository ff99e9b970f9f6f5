// expect: Estimator declares `refine`, but not as
// A refine that is not const used to be ignored without a word: no local optimisation, no final
// refit, a worse fit.
#include <array>
#include <cstddef>
#include <optional>

#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/robust/ransac.hpp>

struct NonConstRefine {
  using Datum = double;
  using Model = double;
  static constexpr std::size_t kSampleSize = 1;
  static constexpr std::size_t kMaxModels = 1;
  using Sample = std::array<Datum, kSampleSize>;
  using Models = diachron::StaticVector<Model, kMaxModels>;
  Models minimal(const Sample& sample) const {
    Models models;
    models.push_back(sample[0]);
    return models;
  }
  double residual(const Model& model, const Datum& datum) const { return datum - model; }
  std::optional<Model> refine(const Model& initial, const diachron::Subset<Datum>&,
                              const double*) {
    return initial;
  }
};

int main() { return diachron::Ransac<NonConstRefine>().options().seed == 0 ? 0 : 1; }
