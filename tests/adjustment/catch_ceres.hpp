// Ceres' headers include glog, whose CHECK(condition) replaces Catch's CHECK (and aborts instead
// of recording a failure). Test files include this after their Ceres-using headers: it includes
// every Ceres header (glog's guard then keeps it from coming back) and gives CHECK back to Catch.
#pragma once

#include <catch2/catch.hpp>
#include <ceres/ceres.h>

#undef CHECK
#define CHECK(...) INTERNAL_CATCH_TEST("CHECK", Catch::ResultDisposition::ContinueOnFailure, __VA_ARGS__)
