# cmake -DA=DIR -DB=DIR -P same_results.cmake: same_results() of scene_folders.cmake for scripts
# (tests/support/match_epochs_slurm.sh).
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
same_results("${A}" "${B}" "${WHAT}")
