# match_epochs on two epoch folders that show different ground (epoch 1 of one small make_scene
# scene, 480 x 360 px and 1 x 2 images, epoch 2 of another seed's): the program must answer "no
# co-registration" with exit 2, still write report.json, and leave the input folders as they were.
# Also refusals of --gcps. (The two epochs of one such scene were this test's case until the
# fallback's winners could be confirmed by the surfaces: they are co-registered now, rightly.)
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DWORK=... -P match_epochs_no_answer.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 480x360 --images-per-epoch 1x2 --seed 1)
execute_process(COMMAND "${MAKE_SCENE}" "${WORK}/other" --image-size 480x360 --images-per-epoch 1x2 --seed 2
                RESULT_VARIABLE made OUTPUT_QUIET ERROR_VARIABLE made_err)
if(NOT made EQUAL 0)
  message(FATAL_ERROR "make_scene failed (${made}): ${made_err}")
endif()
folder_fingerprint("${WORK}/scene" before)
folder_fingerprint("${WORK}/other" other_before)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/other/e2" --out "${WORK}/out" --quiet
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 2)
  message(FATAL_ERROR "match_epochs exited with ${status}, expected 2\n${out}\n${err}")
endif()
if(NOT out MATCHES "no co-registration of e1 with e2: [^\n]+")
  message(FATAL_ERROR "match_epochs gave no reason for its exit 2:\n${out}\n${err}")
endif()
if(NOT EXISTS "${WORK}/out/report.json")
  message(FATAL_ERROR "match_epochs wrote no report.json")
endif()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"success\": *false")
  message(FATAL_ERROR "report.json does not record the failure:\n${report}")
endif()
# The features found nothing, so the dense correlation fallback searched the DSMs, gave no answer,
# and the report says what it cost (and that no answer was taken by its tiles or confirmed by the
# surfaces).
if(NOT report MATCHES "\"correlation_fallback_ran\": true, \"correlation_fallback_used\": false, \"seconds_correlation_fallback\": [0-9.e-]*[1-9][0-9.e-]*, \"correlation_fallback_by_tiles\": false")
  message(FATAL_ERROR "report.json does not record the fallback's run and its time:\n${report}")
endif()
if(NOT report MATCHES "\"correlation_fallback_confirmed_by_surface\": false")
  message(FATAL_ERROR "report.json does not say the surfaces did not confirm a winner:\n${report}")
endif()
if(EXISTS "${WORK}/out/Homol" OR EXISTS "${WORK}/out/rough_helmert_e1.json")
  message(FATAL_ERROR "match_epochs wrote tie points or a Helmert although it found no co-registration")
endif()
# Control and check points are refused before any work: without --adjust, from a malformed file
# (named with its line) and naming an image of neither epoch. refused_gcps(EXPECTED ARGS...): exit 1 and
# EXPECTED on stderr.
function(refused_gcps expected)
  execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out_gcps"
                          --quiet ${ARGN}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 1 OR NOT err MATCHES "${expected}")
    message(FATAL_ERROR "match_epochs --gcps ${ARGN}: exit ${status}, expected 1 with '${expected}'\n${out}\n${err}")
  endif()
endfunction()
refused_gcps("--gcps needs --adjust" --gcps "${WORK}/gcps.txt")
refused_gcps("--check-points needs --adjust" --check-points "${WORK}/gcps.txt")
file(WRITE "${WORK}/gcps.txt" "point A 1 2 3 0.5\nobs A e1_r0_c0.png 10 x\n")
refused_gcps("gcps.txt' line 2: cannot read Y" --adjust --gcps "${WORK}/gcps.txt")
refused_gcps("gcps.txt' line 2: cannot read Y" --adjust --check-points "${WORK}/gcps.txt")
file(WRITE "${WORK}/gcps.txt" "point A 1 2 3 0.5\nobs A no_such_image.png 10 20\n")
refused_gcps("control point A: no image 'no_such_image.png' in any epoch" --adjust --gcps "${WORK}/gcps.txt")
refused_gcps("check point A: no image 'no_such_image.png' in any epoch" --adjust --check-points "${WORK}/gcps.txt")
if(EXISTS "${WORK}/out_gcps")
  message(FATAL_ERROR "match_epochs wrote output although its control points were refused")
endif()
folder_fingerprint("${WORK}/scene" after)
folder_fingerprint("${WORK}/other" other_after)
if(NOT before STREQUAL after OR NOT other_before STREQUAL other_after)
  message(FATAL_ERROR "match_epochs changed its input folders")
endif()
message(STATUS "exit 2 with: ${out}")
