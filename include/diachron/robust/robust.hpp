#pragma once
/// @file
/// Umbrella header of the robust/ module: Ransac, every policy, options, report, and the
/// ransac_similarity2 / ransac_helmert3 convenience functions.

#include <diachron/robust/adaptive_termination.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/bail_out.hpp>
#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/inlier_count_scoring.hpp>
#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/no_local_optimization.hpp>
#include <diachron/robust/prosac_sampler.hpp>
#include <diachron/robust/prosac_termination.hpp>
#include <diachron/robust/ransac.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/ransac_problem.hpp>
#include <diachron/robust/ransac_report.hpp>
#include <diachron/robust/refit_local_optimization.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/robust/uniform_sampler.hpp>
