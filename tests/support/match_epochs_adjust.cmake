# match_epochs --adjust end to end on the smallest make_scene scene that co-registers (800 x 600 px,
# 2 x 2 images per epoch, seed 1): exit 0, every output the docs promise (rough_helmert_e1.json, Homol,
# report.json with the adjustment's section, adjusted/cameras.json and one COLMAP text model per
# epoch, adjusted/colmap/ (all epochs in one model, opened by COLMAP when installed) and
# adjusted/micmac/), the adjusted epoch 1 judged at the scene's check points by score_epochs --check, and the
# inputs unchanged. With 4 of the scene's check points as ground control points (make_scene
# --control-points, match_epochs --gcps): report.json lists each, used, with its error. The scene's
# other check points through match_epochs --check-points: their 3D RMS in report.json at least 3
# times smaller after the adjustment than after the rough co-registration. A prior on f (--prior)
# is listed for epoch 1's camera.
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DSCORE=... -DWORK=... -P match_epochs_adjust.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 800x600 --images-per-epoch 2x2 --seed 1 --control-points 4)
folder_fingerprint("${WORK}/scene" before)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out" --adjust --quiet
                        --gcps "${WORK}/scene/control_points.txt" --check-points "${WORK}/scene/check_points.txt"
                        --prior f=5
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs --adjust exited with ${status}, expected 0\n${out}\n${err}")
endif()
foreach(f rough_helmert_e1.json report.json dod/e1_rough.tif dod/e1_rough.png dod/e1.tif dod/e1.png adjusted/cameras.json adjusted/e1/cameras.txt adjusted/e1/images.txt
          adjusted/e1/points3D.txt adjusted/e2/cameras.txt adjusted/e2/images.txt adjusted/e2/points3D.txt)
  if(NOT EXISTS "${WORK}/out/${f}")
    message(FATAL_ERROR "match_epochs --adjust wrote no ${f}")
  endif()
endforeach()
# All epochs in one COLMAP model with the tie points as points3D, its images/ links, and the MicMac
# orientations: one Orientation file per image of both epochs (2 x 2 each). Debian's COLMAP, when
# installed, opens the model and finds every image and the points.
file(GLOB colmap_links "${WORK}/out/adjusted/colmap/images/*/*.png")
file(GLOB micmac_orientations "${WORK}/out/adjusted/micmac/Ori-diachron/Orientation-*.xml")
list(LENGTH colmap_links colmap_link_count)
list(LENGTH micmac_orientations micmac_count)
if(NOT EXISTS "${WORK}/out/adjusted/colmap/sparse/points3D.txt" OR NOT colmap_link_count EQUAL 8
   OR NOT micmac_count EQUAL 8 OR NOT EXISTS "${WORK}/out/adjusted/micmac/Homol")
  message(FATAL_ERROR "adjusted/colmap (${colmap_link_count} image links) or adjusted/micmac (${micmac_count} "
                      "orientations) is not complete")
endif()
find_program(COLMAP_PROGRAM colmap)
if(COLMAP_PROGRAM)
  execute_process(COMMAND "${COLMAP_PROGRAM}" model_analyzer --path "${WORK}/out/adjusted/colmap/sparse"
                  RESULT_VARIABLE analysed OUTPUT_VARIABLE analysis ERROR_VARIABLE analysis_err)
  string(APPEND analysis "${analysis_err}")
  if(NOT analysed EQUAL 0 OR NOT analysis MATCHES "Registered images: 8" OR NOT analysis MATCHES "Points: [1-9][0-9]*")
    message(FATAL_ERROR "colmap model_analyzer does not open adjusted/colmap/sparse with 8 images and points:\n${analysis}")
  endif()
else()
  message(STATUS "colmap is not installed: adjusted/colmap/sparse not opened by COLMAP")
endif()
file(GLOB homol "${WORK}/out/Homol/Pastis*/*.txt")
if(NOT homol)
  message(FATAL_ERROR "match_epochs --adjust wrote no tie points under Homol/")
endif()
file(GLOB residuals "${WORK}/out/adjusted/residuals/*.png")
if(NOT residuals)
  message(FATAL_ERROR "match_epochs --adjust drew no residual picture under adjusted/residuals/")
endif()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"adjustment\": *{\"success\": *true")
  message(FATAL_ERROR "report.json does not record a successful adjustment:\n${report}")
endif()
# A good scene's run is trusted: no input warning, the cameras graded well.
if(NOT report MATCHES "\"trust\": {\"level\": \"high\", \"reasons\": \\[\\]}")
  message(FATAL_ERROR "report.json does not trust a good scene's run:\n${report}")
endif()
if(NOT report MATCHES "\"affine_scope\": *\"per_image\"")
  message(FATAL_ERROR "report.json does not say where B1, B2 lived (per image by default):\n${report}")
endif()
# The adjustment's own precision figure (the covariance carried to the distortion): epoch 1's camera
# is free, so it has one.
if(NOT report MATCHES "\"camera\": *0, *\"free\": *true, *\"values\": *{[^}]*}[^\n]*\"distortion_sigma\": *{\"worst_px\": *[0-9.e+-]+, *\"rms_px\"")
  message(FATAL_ERROR "report.json gives epoch 1's camera no distortion_sigma:\n${report}")
endif()
# --prior f=5 reaches epoch 1's free camera, and the report lists it; the fixed reference camera has
# none.
if(NOT report MATCHES "\"camera\": *0, [^\n]*\"priors\": *{\"f\": *5}"
   OR NOT report MATCHES "\"camera\": *1, [^\n]*\"priors\": *{}")
  message(FATAL_ERROR "report.json does not list epoch 1's prior on f (and none for epoch 2):\n${report}")
endif()
# Each camera says whose it is: the scene's epochs have one camera each.
if(NOT report MATCHES "\"camera\": *0, [^\n]*\"epoch\": *\"e1\", *\"images\": *[[]\"e1_[^]]*[]]"
   OR NOT report MATCHES "\"camera\": *1, [^\n]*\"epoch\": *\"e2\", *\"images\": *[[]\"e2_")
  message(FATAL_ERROR "report.json does not give each camera its epoch and images:\n${report}")
endif()
# The control points: all four used, each within a tenth of an epoch-2 unit of its position (their
# positions and pixels are exact).
string(REGEX MATCHALL "{\"name\": \"cp[0-9]+\", \"observations\": [0-9]+, \"used\": true, \"error\": \[[^]]*\]}" used_points "${report}")
list(LENGTH used_points used_count)
if(NOT used_count EQUAL 4)
  message(FATAL_ERROR "report.json does not list 4 used control points:\n${report}")
endif()
foreach(p IN LISTS used_points)
  string(REGEX MATCH "\\[([^]]*)\\]" xyz "${p}")
  string(REPLACE "," ";" xyz "${CMAKE_MATCH_1}")
  foreach(v IN LISTS xyz)
    string(STRIP "${v}" v)
    string(REGEX REPLACE "^-" "" size "${v}")
    if(NOT size LESS 0.1)  # a numeric comparison (CMake reads floating point, exponents included)
      message(FATAL_ERROR "control point error ${v} is 0.1 or more: ${p}")
    endif()
  endforeach()
endforeach()
check_points_three_times_better("${report}" "match_epochs --check-points")
# The DoD of epoch 1 before and after the adjustment, with statistics on stable terrain.
if(NOT report MATCHES "\"dod\": {\"stable_radius_cells\": 4,[^\n]*\n *\"e1\": {\"stable_points\": [1-9][0-9]*[^\n]*\n *\"rough\": {\"all\": {\"cells\": [1-9][^\n]*\n *\"adjusted\": {\"all\": {\"cells\": [1-9]")
  message(FATAL_ERROR "report.json has no DoD of epoch 1, rough and adjusted:\n${report}")
endif()
execute_process(COMMAND "${SCORE}" "${WORK}/scene" "${WORK}/out" --check RESULT_VARIABLE scored OUTPUT_VARIABLE score)
if(NOT scored EQUAL 0)
  message(FATAL_ERROR "the adjusted orientation fails its check points (${scored}):\n${score}")
endif()
folder_fingerprint("${WORK}/scene" after)
if(NOT before STREQUAL after)
  message(FATAL_ERROR "match_epochs --adjust changed its input folders")
endif()
message(STATUS "${score}")
