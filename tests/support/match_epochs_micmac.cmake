# match_epochs --adjust end to end on MicMac epochs: the scene of match_epochs_adjust.cmake (800 x 600
# px, 2 x 2 images per epoch, seed 1) written by make_scene --micmac, so that each epoch folder holds
# Ori-SfM/ (the SfM's camera and poses), Homol/ (its tie points) and no COLMAP model. match_epochs
# reads them as MicMac epochs (io/epoch_folder.hpp: the Homol tracks triangulated into the model's
# points), exits 0, writes its own tie points under Homol/ and report.json with a successful
# adjustment; score_epochs (which reads the truth and the scene's Ori-SfM) judges the adjusted epoch
# 1 at the scene's check points with --check; and the inputs are left as they were.
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DSCORE=... -DWORK=... -P match_epochs_micmac.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --micmac --image-size 800x600 --images-per-epoch 2x2 --seed 1)
foreach(epoch e1 e2)
  file(GLOB orientations "${WORK}/scene/${epoch}/Ori-SfM/Orientation-*.xml")
  file(GLOB tie_files "${WORK}/scene/${epoch}/Homol/Pastis*/*.txt")
  list(LENGTH orientations n_orientations)
  if(NOT n_orientations EQUAL 4 OR NOT tie_files)
    message(FATAL_ERROR "make_scene --micmac wrote ${n_orientations} Orientation files (4 expected) and "
                        "tie files '${tie_files}' for ${epoch}")
  endif()
  if(EXISTS "${WORK}/scene/${epoch}/cameras.txt" OR EXISTS "${WORK}/scene/${epoch}/images.txt")
    message(FATAL_ERROR "make_scene --micmac left a COLMAP model in ${epoch}")
  endif()
endforeach()
folder_fingerprint("${WORK}/scene" before)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out" --adjust --quiet
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs --adjust on MicMac epochs exited with ${status}, expected 0\n${out}\n${err}")
endif()
foreach(f rough_helmert_e1.json report.json adjusted/cameras.json)
  if(NOT EXISTS "${WORK}/out/${f}")
    message(FATAL_ERROR "match_epochs --adjust on MicMac epochs wrote no ${f}")
  endif()
endforeach()
file(GLOB homol "${WORK}/out/Homol/Pastis*/*.txt")
if(NOT homol)
  message(FATAL_ERROR "match_epochs --adjust on MicMac epochs wrote no tie points under Homol/")
endif()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"adjustment\": *{\"success\": *true")
  message(FATAL_ERROR "report.json does not record a successful adjustment:\n${report}")
endif()
execute_process(COMMAND "${SCORE}" "${WORK}/scene" "${WORK}/out" --check RESULT_VARIABLE scored OUTPUT_VARIABLE score
                ERROR_VARIABLE score_err)
if(NOT scored EQUAL 0)
  message(FATAL_ERROR "the adjusted orientation of MicMac epochs fails its check points (${scored}):\n${score}\n${score_err}")
endif()
folder_fingerprint("${WORK}/scene" after)
if(NOT before STREQUAL after)
  message(FATAL_ERROR "match_epochs --adjust changed its MicMac input folders")
endif()
message(STATUS "${score}")
