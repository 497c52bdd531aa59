# Sourced by the batch scripts: run_requeueable COMMAND... runs the command in the
# background, forwards SLURM's USR1 (sent --signal=B:USR1@SECONDS before the time limit) to
# it, waits for its exit code, and requeues the job when that is 75 (a checkpoint was written:
# the requeued job continues from it). Returns the command's exit code.
run_requeueable() {
    "$@" 2> >(quiet_checkpoint_exit >&2) &
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

# mpirun reports a rank's non-zero exit in two boxed blocks ("Primary job terminated
# normally, but 1 process returned a non-zero exit code..."). After a checkpoint (exit 75)
# that is the planned way out of a time limit: the blocks become one line. Any other exit
# code keeps them as mpirun wrote them. Every other line passes at once.
quiet_checkpoint_exit() {
    awk '
        function close_block() {
            if (block ~ /Per user-direction, the job has been aborted/) { pending = pending block }
            else if (block ~ /Exit code: +75\n/) { print "mpirun: every rank wrote its checkpoint part and stopped (exit 75)"; pending = "" }
            else { printf "%s%s", pending, block; pending = "" }
            block = ""; fflush()
        }
        /^-----+$/ { block = block $0 "\n"; if (open) { open = 0; close_block() } else { open = 1 }; next }
        open { block = block $0 "\n"; next }
        { if (pending != "") { printf "%s", pending; pending = "" } print; fflush() }
        END { printf "%s%s", pending, block }
    '
}
