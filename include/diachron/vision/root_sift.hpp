#pragma once
/// @file
/// RootSiftExtractor: SIFT with RootSIFT descriptors. It lives in sift.hpp (one class, one option);
/// this header exists so `#include <diachron/vision/root_sift.hpp>` finds it under its own name.

#include <diachron/vision/sift.hpp>
