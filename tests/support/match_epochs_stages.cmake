# match_epochs in stages (issue 48): plan, run-pair, merge give byte for byte the one-process run's
# results, on the small make_scene scene (480 x 360 px, 1 x 2 images, seed 1), with --adjust; and
# the stages refuse what would give a wrong or incomplete answer:
# - a job run twice: the second run does nothing ("already done");
# - a merge with a job's result missing: exit 1, the job named with the command that makes it;
# - a pair result of another plan: refused;
# - inputs changed since the plan (an image rewritten): run-pair and merge refuse, naming the epoch;
# - a plan of another version: refused with the remedy;
# - run-pair's job from SLURM_ARRAY_TASK_ID, its threads from SLURM_CPUS_PER_TASK;
# - plan --emit slurm: array scripts cut at --slurm-max-array, a merge after all of them (afterok).
#   cmake -DMAKE_SCENE=... -DMATCH_EPOCHS=... -DWORK=... -P match_epochs_stages.cmake
include("${CMAKE_CURRENT_LIST_DIR}/scene_folders.cmake")
fresh_scene("${WORK}" --image-size 480x360 --images-per-epoch 1x2 --seed 1)
set(e1 "${WORK}/scene/e1")
set(e2 "${WORK}/scene/e2")
set(options --adjust --threads 2 --quiet)

function(run_ok what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${what}: exit ${status}\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

function(run_refused what expected)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 1 OR NOT err MATCHES "${expected}")
    message(FATAL_ERROR "${what}: exit ${status}, expected 1 with '${expected}'\n${out}\n${err}")
  endif()
endfunction()

# The one-process run, then the same in stages.
run_ok("one-process run" "${MATCH_EPOCHS}" "${e1}" "${e2}" --out "${WORK}/whole" ${options})
run_ok("plan" "${MATCH_EPOCHS}" plan "${e1}" "${e2}" --out "${WORK}/staged" ${options})
if(NOT out MATCHES "plan: ([0-9]+) pair jobs")
  message(FATAL_ERROR "plan does not say how many jobs:\n${out}")
endif()
set(jobs ${CMAKE_MATCH_1})
if(jobs LESS 2)
  message(FATAL_ERROR "the scene gives ${jobs} pair jobs; the test needs 2 or more")
endif()
math(EXPR last "${jobs} - 1")
execute_process(COMMAND "${CMAKE_COMMAND}" -E compare_files "${WORK}/whole/jobs.tsv" "${WORK}/staged/jobs.tsv"
                RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "jobs.tsv of the plan differs from the one-process run's")
endif()
set(plan "${WORK}/staged/plan.json")
# Job 0 as a Slurm array task would run it; the rest as a range.
set(ENV{SLURM_ARRAY_TASK_ID} 0)
set(ENV{SLURM_CPUS_PER_TASK} 1)
run_ok("run-pair from SLURM_ARRAY_TASK_ID" "${MATCH_EPOCHS}" run-pair --plan "${plan}" --quiet)
unset(ENV{SLURM_ARRAY_TASK_ID})
unset(ENV{SLURM_CPUS_PER_TASK})
if(NOT out MATCHES "pair jobs 0 of [^\n]*: 1 run, 0 already done, 0 failed")
  message(FATAL_ERROR "run-pair did not take its job from SLURM_ARRAY_TASK_ID:\n${out}")
endif()
# A merge before every job ran: refused, the missing jobs named with the command that makes them.
run_refused("merge with jobs missing" "have no result[^\n]*\\(1(-${last})?\\)[^\n]*\n  match_epochs run-pair --plan [^\n]* --range 1-${last}"
            "${MATCH_EPOCHS}" merge --plan "${plan}" --quiet)
if(EXISTS "${WORK}/staged/Homol" OR EXISTS "${WORK}/staged/report.json")
  message(FATAL_ERROR "a refused merge wrote outputs")
endif()
run_ok("run-pair --range" "${MATCH_EPOCHS}" run-pair --plan "${WORK}/staged" --range 1-${last} --threads 2 --quiet)
# Run twice: nothing done again.
run_ok("run-pair again" "${MATCH_EPOCHS}" run-pair --plan "${plan}" --range 0-${last} --quiet)
if(NOT out MATCHES ": 0 run, ${jobs} already done, 0 failed")
  message(FATAL_ERROR "jobs run twice were computed again:\n${out}")
endif()
run_refused("a job beyond the plan" "job ${jobs} is not in the plan" "${MATCH_EPOCHS}" run-pair --plan "${plan}"
            --index ${jobs} --quiet)
run_ok("merge" "${MATCH_EPOCHS}" merge --plan "${plan}" --quiet)
same_results("${WORK}/whole" "${WORK}/staged" "plan / run-pair / merge against the one-process run")
# A merge again gives the same (it replaces its own outputs, keeps the plan's).
run_ok("merge again" "${MATCH_EPOCHS}" merge --plan "${plan}" --quiet)
same_results("${WORK}/whole" "${WORK}/staged" "a second merge")

# A job's result of another plan: refused by the merge.
file(READ "${WORK}/staged/jobs/000000.json" job0)
string(REGEX REPLACE "\"plan_id\": \"[0-9a-f]+\"" "\"plan_id\": \"0123456789abcdef\"" foreign "${job0}")
file(WRITE "${WORK}/staged/jobs/000000.json" "${foreign}")
run_refused("a result of another plan" "belong to another plan" "${MATCH_EPOCHS}" merge --plan "${plan}" --quiet)
file(WRITE "${WORK}/staged/jobs/000000.json" "${job0}")

# A plan of another version: refused with the remedy.
file(READ "${plan}" plan_text)
string(REPLACE "\"version\": \"" "\"version\": \"0.0.0-other-" other "${plan_text}")
file(WRITE "${WORK}/other_version.json" "${other}")
run_refused("a plan of another version" "was made by diachron 0.0.0-other-[^\n]*run match_epochs plan again"
            "${MATCH_EPOCHS}" run-pair --plan "${WORK}/other_version.json" --index 0 --quiet)

# Inputs changed since the plan: an image rewritten (same bytes, a new time) is refused by both.
file(GLOB images "${e1}/images/*")
list(GET images 0 image)
execute_process(COMMAND "${CMAKE_COMMAND}" -E sleep 1)
execute_process(COMMAND "${CMAKE_COMMAND}" -E touch "${image}")
run_refused("run-pair after the inputs changed" "input files of epoch e1[^\n]*changed since the plan"
            "${MATCH_EPOCHS}" run-pair --plan "${plan}" --index 0 --quiet)
run_refused("merge after the inputs changed" "input files of epoch e1[^\n]*changed since the plan"
            "${MATCH_EPOCHS}" merge --plan "${plan}" --quiet)

# --emit slurm: arrays of at most 1 task each here, a merge after all of them.
run_ok("plan --emit slurm" "${MATCH_EPOCHS}" plan "${e1}" "${e2}" --out "${WORK}/slurm" ${options} --emit slurm
       --slurm-max-array 1 --slurm-cpus 2)
file(GLOB arrays "${WORK}/slurm/slurm/pairs_*.sbatch")
list(LENGTH arrays n)
if(NOT n EQUAL jobs)
  message(FATAL_ERROR "--slurm-max-array 1 with ${jobs} jobs wrote ${n} array scripts")
endif()
file(READ "${WORK}/slurm/slurm/pairs_0.sbatch" array0)
file(READ "${WORK}/slurm/slurm/submit.sh" submit)
if(NOT array0 MATCHES "#SBATCH --array=0-0\n#SBATCH --cpus-per-task=2\n" OR NOT array0 MATCHES "run-pair --plan '[^']*/slurm/plan.json' --range"
   OR NOT submit MATCHES "--dependency=\"\\$depend\"" OR NOT submit MATCHES "depend=\"\\$depend:")
  message(FATAL_ERROR "the Slurm scripts are not as planned:\n${array0}\n${submit}")
endif()
