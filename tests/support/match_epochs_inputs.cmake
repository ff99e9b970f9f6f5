# match_epochs against inputs that disagree and outputs that must stay true (issue 47), on the small
# make_scene scene (480 x 360 px, 1 x 2 images, seed 1):
# - epoch 1's model moved 130 units up against its DSM (make_scene --model-offset): refused before
#   any matching, exit 1, the figures and a remedy on stderr, --out not created;
# - numbers parsed strictly, named by their flag;
# - progress as whole lines when stderr is not a terminal;
# - a non-empty --out refused without --overwrite; with it, an earlier run's outputs (stale tie
#   points, pictures, Helmert files) replaced, the user's own files kept, no partial folder left;
#   a rerun that fails leaves the earlier outputs as they were.
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DWORK=... -P match_epochs_inputs.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 480x360 --images-per-epoch 1x2 --seed 1)
execute_process(COMMAND "${MAKE_SCENE}" "${WORK}/offset" --image-size 480x360 --images-per-epoch 1x2 --seed 1
                        --model-offset e1=0,0,130
                RESULT_VARIABLE made OUTPUT_QUIET ERROR_VARIABLE made_err)
if(NOT made EQUAL 0)
  message(FATAL_ERROR "make_scene --model-offset failed (${made}): ${made_err}")
endif()

# The model far above its DSM: refused with the figures (the median height difference) and a remedy.
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/offset/e1" "${WORK}/offset/e2" --out "${WORK}/refused" --adjust
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 1)
  message(FATAL_ERROR "a model 130 units off its DSM: exit ${status}, expected 1\n${out}\n${err}")
endif()
if(NOT err MATCHES "epoch '[^']*/offset/e1': its model and its DSM disagree: [^\n]*median 1[23][0-9]"
   OR NOT err MATCHES "remedy: bring the model into the DSM's frame[^\n]*moving the model by \\([^)]*-1[23][0-9][^)]*\\)")
  message(FATAL_ERROR "the refusal does not give the offset and the remedy:\n${err}")
endif()
if(EXISTS "${WORK}/refused" OR out MATCHES "tentative")
  message(FATAL_ERROR "match_epochs matched or wrote output although it refused its inputs:\n${out}")
endif()

# Numbers parsed strictly, the flag named.
function(refused_option expected)
  execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/unused" ${ARGN}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 1 OR NOT err MATCHES "${expected}" OR EXISTS "${WORK}/unused")
    message(FATAL_ERROR "match_epochs ${ARGN}: exit ${status}, expected 1 with '${expected}' and no output\n${err}")
  endif()
endfunction()
refused_option("--threads: '-1' is not a whole number" --threads -1)
refused_option("--threads: 'abc' is not a whole number" --threads abc)
refused_option("--min-overlap: '0.5x' is not a number" --min-overlap 0.5x)
refused_option("--min-overlap: it wants a share in \\[0, 1\\], got 2" --min-overlap 2)
refused_option("--cell: it wants a cell side in \\[2, 4096\\] px, got 1" --cell 1)

# A run into a new folder: progress on stderr as whole lines (no carriage return into a file).
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out"
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "match_epochs exited with ${status}\n${out}\n${err}")
endif()
string(FIND "${err}" "\r" carriage)
if(NOT carriage EQUAL -1 OR NOT err MATCHES "precise matching \\(pairs\\): 0/[0-9]+")
  message(FATAL_ERROR "progress into a file is not whole lines:\n${err}")
endif()
file(READ "${WORK}/out/report.json" report)
if(NOT report MATCHES "\"run\": {\"command_line\": \\[\"[^\"]*match_epochs\", \"[^\"]*scene/e1\"[^]]*\\], \"version\": \"[0-9.]+\", \"threads\": [1-9][0-9]*, \"started\": \"[0-9T:Z-]+\", \"plan_id\": \"[0-9a-f]+\", \"inputs\": {\"epochs\": \\[\"/[^\"]*/scene/e1\", \"/[^\"]*/scene/e2\"\\], \"gcps\": null, \"check_points\": null}, \"seconds\": {[^}]*\"precise matching\": [0-9.e-]+[^}]*\"total\": [0-9.e-]+}, \"peak_memory_bytes\": [0-9]+}"
   OR NOT report MATCHES "\"trust\": {\"level\": \"high\", \"reasons\": \\[\\]}"
   OR NOT report MATCHES "\"input_checks\": {[^\n]*\n *\"e1\": {\"model_dsm\": {\"verdict\": \"agree\"")
  message(FATAL_ERROR "report.json lacks the run, the trust or the input checks:\n${report}")
endif()
file(GLOB pictures "${WORK}/out/pairs/*__*.jpg")
if(NOT pictures)
  message(FATAL_ERROR "no pair picture <a>__<b>.jpg in pairs/")
endif()
foreach(p IN LISTS pictures)
  file(SIZE "${p}" bytes)
  if(bytes GREATER 1000000)
    message(FATAL_ERROR "${p} is ${bytes} bytes, more than 1 MB")
  endif()
endforeach()

# A second run into it: refused without --overwrite, nothing touched.
folder_fingerprint("${WORK}/out" first)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out" --quiet
                RESULT_VARIABLE status ERROR_VARIABLE err)
folder_fingerprint("${WORK}/out" second)
if(NOT status EQUAL 1 OR NOT err MATCHES "is not empty \\(it holds Homol, [^)]*\\): give a new or empty folder, or --overwrite"
   OR NOT first STREQUAL second)
  message(FATAL_ERROR "a run into a full --out without --overwrite: exit ${status}\n${err}")
endif()

# Stale outputs of an earlier run and a file of the user's, then a rerun with --overwrite that fails
# (the offset model): everything stays as it was.
file(WRITE "${WORK}/out/Homol/Pastisstale.png/old.png.txt" "1 2 3 4\n")
file(WRITE "${WORK}/out/pairs/old__older.jpg" "x")
file(WRITE "${WORK}/out/rough_helmert_e0.json" "{}")
file(WRITE "${WORK}/out/my_notes.txt" "mine")
folder_fingerprint("${WORK}/out" with_stale)
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/offset/e1" "${WORK}/offset/e2" --out "${WORK}/out" --overwrite --quiet
                RESULT_VARIABLE status ERROR_VARIABLE err)
folder_fingerprint("${WORK}/out" after_failure)
if(NOT status EQUAL 1 OR NOT with_stale STREQUAL after_failure)
  message(FATAL_ERROR "a failed rerun with --overwrite changed --out (exit ${status}):\n${err}")
endif()
# The same rerun on good inputs: the stale outputs gone, the user's file kept, no partial folder.
execute_process(COMMAND "${MATCH_EPOCHS}" "${WORK}/scene/e1" "${WORK}/scene/e2" --out "${WORK}/out" --overwrite --quiet
                RESULT_VARIABLE status OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "the rerun with --overwrite exited with ${status}\n${err}")
endif()
file(GLOB partial "${WORK}/out/.match_epochs-partial-*")
if(EXISTS "${WORK}/out/Homol/Pastisstale.png" OR EXISTS "${WORK}/out/pairs/old__older.jpg"
   OR EXISTS "${WORK}/out/rough_helmert_e0.json" OR NOT EXISTS "${WORK}/out/my_notes.txt"
   OR NOT EXISTS "${WORK}/out/report.json" OR NOT EXISTS "${WORK}/out/rough_helmert_e1.json" OR partial)
  message(FATAL_ERROR "--overwrite left stale outputs, lost the user's file or left a partial folder")
endif()
