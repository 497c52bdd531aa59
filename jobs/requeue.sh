# Sourced by the batch scripts: run_requeueable COMMAND... runs the command in the
# background, forwards SLURM's USR1 (sent --signal=B:USR1@SECONDS before the time limit) to
# it, waits for its exit code, and requeues the job when that is 75 (a checkpoint was written:
# the requeued job continues from it). Returns the command's exit code.
run_requeueable() {
    "$@" &
    local runner=$!
    trap 'kill -USR1 "$runner"' USR1
    # wait returns early when the trap fires; wait again for the checkpoint and the exit code
    wait "$runner"; local code=$?
    while kill -0 "$runner" 2>/dev/null; do wait "$runner"; code=$?; done
    if [ "$code" -eq 75 ] && [ -n "${SLURM_JOB_ID:-}" ]; then
        echo "$(date -Is) checkpoint written: requeueing job $SLURM_JOB_ID"
        scontrol requeue "$SLURM_JOB_ID"
    fi
    return "$code"
}
