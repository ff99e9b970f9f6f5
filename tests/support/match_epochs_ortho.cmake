# match_epochs with an orthophoto reference, end to end: make_scene --ortho-reference delivers the
# recent epoch as a true orthophoto and its true surface (no model, no images); match_epochs
# co-registers the DSMs, matches epoch 1's photos with the orthophoto's tiles and adjusts epoch 1
# against them (--adjust; the orthophoto is the fixed reference). Checked: exit 0, Homol/ names the
# tiles, report.json says the epochs' kinds, the rough transform's source and a successful
# adjustment, and epoch 1's check points at least 3 times closer after the adjustment than after the
# rough co-registration. Then the orthophoto as epoch 1 with --adjust, refused before any work
# (exit 1, nothing written), a given transform (--rough FILE) under which nothing overlaps
# (exit 2, "no overlapping pair"), and one a few units off (exit 0, most of the matches).
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DWORK=... -P match_epochs_ortho.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 800x600 --images-per-epoch 2x2 --seed 1 --control-points 4 --ortho-reference)
if(NOT EXISTS "${WORK}/scene/e2/ortho.tif" OR EXISTS "${WORK}/scene/e2/images.txt")
  message(FATAL_ERROR "make_scene --ortho-reference wrote no orthophoto epoch e2")
endif()
folder_fingerprint("${WORK}/scene" before)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out" --adjust --quiet
                        --check-points "${WORK}/scene/check_points.txt" --no-pictures
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs against an orthophoto exited with ${status}, expected 0\n${out}\n${err}")
endif()
file(GLOB homol RELATIVE "${WORK}/out/Homol" "${WORK}/out/Homol/Pastis*/ortho_x*_y*.tif.txt")
if(NOT homol)
  file(GLOB_RECURSE all RELATIVE "${WORK}/out" "${WORK}/out/Homol/*")
  message(FATAL_ERROR "Homol/ names no orthophoto tile (ortho_x<X>_y<Y>.tif):\n${all}")
endif()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"kind\": \"photos\", \"images\": 4,[^\n]*\n[^\n]*\n *{\"name\": \"e2\"[^\n]*\"kind\": \"orthophoto\", \"images\": [0-9]+")
  message(FATAL_ERROR "report.json does not give the epochs' kinds:\n${report}")
endif()
if(NOT report MATCHES "\"rough_coregistration\": {\"source\": \"dsm\", \"via\": null, \"success\": true")
  message(FATAL_ERROR "report.json does not say the rough transform came from the DSMs:\n${report}")
endif()
if(NOT report MATCHES "\"adjustment\": *{\"success\": *true")
  message(FATAL_ERROR "report.json does not record a successful adjustment:\n${report}")
endif()
check_points_three_times_better("${report}" "orthophoto reference")
folder_fingerprint("${WORK}/scene" after)
if(NOT before STREQUAL after)
  message(FATAL_ERROR "match_epochs changed its input folders")
endif()

# The orthophoto as epoch 1 with --adjust: refused before any work, with the reason.
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e2" "${WORK}/scene/e1" --out "${WORK}/refused" --adjust --quiet
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 1 OR NOT err MATCHES "orthophoto can only be the reference" OR EXISTS "${WORK}/refused")
  message(FATAL_ERROR "an orthophoto as epoch 1 with --adjust: exit ${status}, expected 1 with the reason and no output\n${err}")
endif()

# A given transform under which nothing overlaps: exit 2 with the reason, as a failed co-registration.
file(WRITE "${WORK}/far.json"
     "{\"scale\": 1.0, \"rotation\": [1, 0, 0, 0, 1, 0, 0, 0, 1], \"translation\": [1.0e7, 0, 0]}\n")
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/far" --rough "${WORK}/far.json"
                        --quiet
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 2 OR NOT out MATCHES "no overlapping pair")
  message(FATAL_ERROR "--rough FILE with no overlap: exit ${status}, expected 2 and 'no overlapping pair'\n${out}\n${err}")
endif()

# A given transform a little wrong, as a previous run or GCPs give: the DSM co-registration's own
# rough_helmert_e1.json from the first run, moved 10 epoch-2 units along X (5.3 m on this scene's
# ground, about 5 of epoch 1's pixels: inside the correlation's +-12 px search). The second pass
# around the refitted transform recovers: exit 0, the report names the file, and at least half the
# first run's final matches.
file(READ "${WORK}/out/rough_helmert_e1.json" given)
string(REGEX MATCH "\"translation\": \\[([-0-9.e+]+)," tx "${given}")
if(NOT tx)
  message(FATAL_ERROR "rough_helmert_e1.json has no translation:\n${given}")
endif()
set(x "${CMAKE_MATCH_1}")
if(x MATCHES "[eE]")
  message(FATAL_ERROR "the test moves a translation written in decimals, got ${x}")
endif()
# 10 units more in magnitude, on the decimal text (CMake's math is integer-only): the integer part
# grows by 10, so x moves 10 units away from 0, east or west.
string(REGEX MATCH "^(-?)([0-9]+)(.*)$" _parts "${x}")
set(sign "${CMAKE_MATCH_1}")
set(rest "${CMAKE_MATCH_3}")
math(EXPR int_part "${CMAKE_MATCH_2} + 10")
string(REPLACE "\"translation\": [${x}," "\"translation\": [${sign}${int_part}${rest}," shifted "${given}")
file(WRITE "${WORK}/shifted.json" "${shifted}")
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/shifted" --rough
                        "${WORK}/shifted.json" --quiet --no-pictures
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "--rough FILE 10 units off: exit ${status}, expected 0\n${out}\n${err}")
endif()
file(READ "${WORK}/shifted/report.json" shifted_report)
if(NOT shifted_report MATCHES "\"rough_coregistration\": {\"source\": \"file\"")
  message(FATAL_ERROR "report.json does not say the rough transform came from the file:\n${shifted_report}")
endif()
string(REGEX MATCH "\"final\": ([0-9]+)" _m "${report}")
set(first_final "${CMAKE_MATCH_1}")
string(REGEX MATCH "\"final\": ([0-9]+)" _m "${shifted_report}")
set(shifted_final "${CMAKE_MATCH_1}")
math(EXPR twice "2 * ${shifted_final}")
if(NOT first_final OR twice LESS first_final)
  message(FATAL_ERROR "--rough FILE 10 units off: ${shifted_final} final matches, against ${first_final} from the DSMs' own transform")
endif()
message(STATUS "--rough FILE 10 units off: ${shifted_final} final matches (${first_final} from the DSMs' own transform)")
