# match_epochs with three epochs (make_scene --epochs 3: two film-like epochs and a recent
# reference; 800 x 600 px, 2 x 2 images each, seed 1): exit 0; each free epoch co-registered with
# the reference (rough_helmert_<epoch>.json); tie points between every two epochs, the two free
# epochs' too; one combined adjustment whose report ties every epoch to the others; each free
# epoch's DoD before and after it; both free epochs judged at the scene's check points by
# score_epochs --check. Then the epochs given in another order (the reference named): the same
# tie points, byte for byte.
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DSCORE=... -DWORK=... -P match_epochs_three.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 800x600 --images-per-epoch 2x2 --seed 1 --epochs 3 --check-points 60)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" "${WORK}/scene/e3" --out "${WORK}/out"
                        --adjust --quiet
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs e1 e2 e3 --adjust exited with ${status}, expected 0\n${out}\n${err}")
endif()
foreach(f rough_helmert_e1.json rough_helmert_e2.json report.json adjusted/cameras.json adjusted/e1/images.txt
          adjusted/e2/images.txt adjusted/e3/images.txt dod/e1_rough.tif dod/e1.png dod/e2_rough.png dod/e2.tif)
  if(NOT EXISTS "${WORK}/out/${f}")
    message(FATAL_ERROR "match_epochs e1 e2 e3 --adjust wrote no ${f}")
  endif()
endforeach()
if(EXISTS "${WORK}/out/rough_helmert_e3.json")
  message(FATAL_ERROR "the reference e3 got a rough transform of its own")
endif()
# Homol: every two epochs tied, both directions (the scene's image names are e<k>_r<R>_c<C>.png).
foreach(pair "e1;e2" "e1;e3" "e2;e3")
  list(GET pair 0 a)
  list(GET pair 1 b)
  file(GLOB forward "${WORK}/out/Homol/Pastis${a}_*/${b}_*.txt")
  file(GLOB backward "${WORK}/out/Homol/Pastis${b}_*/${a}_*.txt")
  if(NOT forward OR NOT backward)
    message(FATAL_ERROR "Homol/ has no tie points between ${a} and ${b} in both directions")
  endif()
endforeach()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"adjustment\": *{\"success\": *true")
  message(FATAL_ERROR "report.json does not record a successful adjustment:\n${report}")
endif()
foreach(pair "e1\", \"e2" "e1\", \"e3" "e2\", \"e3")
  if(NOT report MATCHES "{\"epochs\": \\[\"${pair}\"\\], \"tracks\": [1-9][0-9]*}")
    message(FATAL_ERROR "report.json's epoch_links do not tie ${pair}:\n${report}")
  endif()
endforeach()
if(NOT report MATCHES "\"reference\": \"e3\"")
  message(FATAL_ERROR "report.json does not name e3 the reference:\n${report}")
endif()
execute_process(COMMAND "${SCORE}" "${WORK}/scene" "${WORK}/out" --check RESULT_VARIABLE scored OUTPUT_VARIABLE score)
if(NOT scored EQUAL 0)
  message(FATAL_ERROR "the adjusted free epochs fail their check points (${scored}):\n${score}")
endif()
string(REGEX MATCHALL "3D RMS of e[12][^\n]*" rms "${score}")
message(STATUS "${rms}")

# Another order, the reference named: the same tie points.
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e3" "${WORK}/scene/e2" "${WORK}/scene/e1" --reference e3
                        --out "${WORK}/reordered" --quiet --no-pictures
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs e3 e2 e1 --reference e3 exited with ${status}, expected 0\n${out}\n${err}")
endif()
folder_fingerprint("${WORK}/out/Homol" first)
folder_fingerprint("${WORK}/reordered/Homol" second)
if(NOT first STREQUAL second)
  message(FATAL_ERROR "the epochs' order changed the tie points")
endif()
