#!/usr/bin/env bash
# Tests the SLURM scripts on a real SLURM: stands up a single-node cluster on 127.0.0.1 (its
# own munged, slurmctld and slurmd, configuration and ports, as root), submits a small V50
# campaign (about a minute of shots) through jobs/v50-campaign.sbatch with a one-minute limit
# and USR1 55 seconds before it (slurmctld looks every 30 s), so that the job is signalled
# mid-campaign, checkpoints, requeues itself and
# resumes; then checks that it was requeued and that every shot equals an uninterrupted run
# outside SLURM, bit for bit. The daemons are stopped by their process ids.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/mpi-env.sh
source scripts/packages.sh
ensure_packages slurm-test slurm-wlm munge
bin=target/release/dea-mpi
work=$(mktemp -d /tmp/dea-slurm.XXXXXX)
chmod 755 "$work"
pids=()
cleanup() {
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    sleep 1
    for pid in "${pids[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
    rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL slurm: $*"; for f in "$work"/log/*.log "$work"/job.log; do [ -f "$f" ] && { echo "--- $f"; tail -n 30 "$f"; }; done; exit 1; }

echo "reference: the campaign outside SLURM"
"${MPIRUN[@]}" -np 2 "$bin" v50 cases/v50_slurm_test.json --out "$work/reference" --ranks-per-shot 1 >"$work/reference.log" 2>&1 || fail "reference run"

# munge with its own key and socket
mkdir -p "$work/munge" "$work/log" "$work/state" "$work/spool"
chmod 711 "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=128 count=1 status=none
chmod 400 "$work/munge/munge.key"
/usr/sbin/munged --force --socket="$work/munge/socket" --key-file="$work/munge/munge.key" --pid-file="$work/munge/munged.pid" \
    --log-file="$work/log/munged.log" --seed-file="$work/munge/seed"
pids+=("$(cat "$work/munge/munged.pid")")

host=$(hostname -s)
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=deatest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmctldPort=6917
SlurmdPort=6918
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobRequeue=1
MinJobAge=600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
/usr/sbin/slurmctld -i -f "$SLURM_CONF"
for _ in $(seq 50); do [ -s "$work/slurmctld.pid" ] && break; sleep 0.2; done
pids+=("$(cat "$work/slurmctld.pid")")
/usr/sbin/slurmd -f "$SLURM_CONF"
for _ in $(seq 50); do [ -s "$work/slurmd.pid" ] && break; sleep 0.2; done
pids+=("$(cat "$work/slurmd.pid")")
for _ in $(seq 60); do sinfo -h -o %t 2>/dev/null | grep -qE '^(idle|mix)' && break; sleep 1; done
sinfo -h -o %t | grep -qE '^(idle|mix)' || fail "the node did not come up: $(sinfo 2>&1)"
echo "slurm: $(sinfo -h -o '%P %D %t %c') up"

job=$(sbatch --parsable --ntasks=2 --time=1 --signal=B:USR1@55 --output="$work/job.log" \
    jobs/v50-campaign.sbatch cases/v50_slurm_test.json "$work/slurm" 1) || fail "sbatch"
echo "submitted job $job"
state="" extended=""
for _ in $(seq 600); do
    info=$(scontrol show job "$job" 2>/dev/null || true)
    state=$(grep -o 'JobState=[A-Z_]*' <<<"$info" | cut -d= -f2 || true)
    [ "$state" = COMPLETED ] || [ "$state" = FAILED ] || [ "$state" = CANCELLED ] && break
    # once requeued, the resumed job gets time to finish (SLURM would signal it again five
    # seconds in, and requeue it until done: correct, but slow)
    if [ -z "$extended" ] && grep -q 'Restarts=[1-9]' <<<"$info"; then
        scontrol update JobId="$job" TimeLimit=10 && extended=yes
        scontrol release "$job" 2>/dev/null || true
    fi
    sleep 1
done
restarts=$(scontrol show job "$job" | grep -o 'Restarts=[0-9]*' | cut -d= -f2)
echo "job $job: $state after $restarts requeue(s)"
[ "$state" = COMPLETED ] || fail "job ended $state"
[ "${restarts:-0}" -ge 1 ] || fail "the job was never requeued: the time-limit path was not exercised"
grep -q "checkpoint written: requeueing" "$work/job.log" || fail "no checkpoint before the requeue"
ls "$work"/slurm/shots/*/checkpoint/manifest.h5 >/dev/null 2>&1 || fail "no shot was interrupted mid-run"
for shot in "$work"/reference/shots/*/; do
    "$bin" compare "$shot/results.h5" "$work/slurm/shots/$(basename "$shot")/results.h5" >/dev/null || fail "shot $(basename "$shot") differs"
done
/usr/bin/python3 - "$work/reference/v50.json" "$work/slurm/v50.json" <<'PY' || fail "v50.json differs"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:])
key = lambda s: (s["id"], s["velocity_m_s"], s["seed"], s["perforated"], s["residual_velocity_m_s"], s["steps"])
assert [key(s) for s in a["shots"]] == [key(s) for s in b["shots"]], "shot records differ"
assert a["mil_std_662f"] == b["mil_std_662f"] and a["lambert_jonas"] == b["lambert_jonas"]
print(f"{len(a['shots'])} shots identical")
PY
# the requeued campaign's closing report counts what the uninterrupted one counts, and the
# requeue reads as a checkpoint line, not mpirun's boxed abort report
counts() { grep -o '[0-9]* shots ([0-9]* partial, [0-9]* complete)' "$1" | tail -n 1; grep -o 'warning: [0-9]* partial(s) were still undecided' "$1" | tail -n 1; }
[ "$(counts "$work/job.log")" = "$(counts "$work/reference.log")" ] \
    || fail "the closing counts differ: $(counts "$work/job.log") against $(counts "$work/reference.log")"
grep -q "every rank wrote its checkpoint part and stopped (exit 75)" "$work/job.log" || fail "no one-line checkpoint stop in the job log"
! grep -q "Primary job" "$work/job.log" || fail "mpirun's abort report in the job log after a checkpoint stop"
echo "ok   slurm: requeued $restarts time(s), resumed from checkpoints, every shot equal to the run outside SLURM, the same counts"
