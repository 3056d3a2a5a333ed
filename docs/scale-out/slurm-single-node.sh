#!/usr/bin/env bash
# Runs the Slurm array recipe (slurm-array.sh) for real, on this machine made a one-node Slurm
# cluster, and checks its merged folder against the unsharded run, file for file.
#
#   sudo docs/scale-out/slurm-single-node.sh [WORK]     (default WORK: /tmp/mapkeeper-slurm)
#
# What it does, in order:
#   1. installs Debian's slurm-wlm and munge if they are missing (apt-get; needs root);
#   2. builds the release binary if MAPKEEPER is not set and target/release/mapkeeper is missing;
#   3. starts munged with the package's key (creating one if there is none);
#   4. writes WORK/slurm/slurm.conf for this node alone (its CPUs and memory from `slurmd -C`,
#      no accounting, no cgroups) and starts slurmctld and slurmd with it;
#   5. submits the array (SHARDS tasks, default 3) and the merge with --dependency=afterok,
#      exactly as docs/scale-out.md tells a cluster user, and waits for both;
#   6. runs the same sweep unsharded and compares the two folders (`diff -r`); exit 1 if they
#      differ or a job did not complete;
#   7. stops the daemons it started (KEEP_SLURM=1 leaves them running).
#
# The sweep is VALIDATE_ARGS (default: two presets, three seeds, five worlds, --no-timing so
# that the files compare byte for byte). Not part of .ci/run: it installs system packages and
# starts daemons. Its output on the project's machine is in docs/scale-out.md.
set -euo pipefail
work=${1:-/tmp/mapkeeper-slurm}
repo=$(cd "$(dirname "$0")/../.." && pwd)
shards=${SHARDS:-3}
args=${VALIDATE_ARGS:---presets paper,mapkeeper --seeds 3 --worlds 5 --no-timing}
case "$shards" in
    *[!0-9]* | '' | 0*) echo "$0: SHARDS must be a whole number ≥ 1, got '$shards'" >&2; exit 2 ;;
esac
if [ "$(id -u)" != 0 ]; then
    echo "$0: run as root: it installs packages and starts munged, slurmctld and slurmd" >&2
    exit 2
fi
say() { printf '[slurm-single-node] %s\n' "$*"; }

# 1. Packages.
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
    say "installing slurm-wlm and munge"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge
fi
say "$(slurmctld -V), $(munged --version 2>&1 | head -1)"

# 2. The binary.
bin=${MAPKEEPER:-$repo/target/release/mapkeeper}
if [ ! -x "$bin" ]; then
    say "building $bin"
    (cd "$repo" && cargo build --release --locked -p mapkeeper)
fi

# 3. munge.
install -d -o munge -g munge -m 0755 /run/munge
if [ ! -s /etc/munge/munge.key ]; then
    runuser -u munge -- mungekey --create --keyfile /etc/munge/munge.key
fi
if ! pgrep -x munged >/dev/null; then
    runuser -u munge -- /usr/sbin/munged
fi
munge -n | unmunge >/dev/null
say "munge credentials round-trip"

# 4. Slurm for this node alone.
if pgrep -x slurmctld >/dev/null || pgrep -x slurmd >/dev/null; then
    echo "$0: a slurmctld or slurmd is already running on this machine; stop it first (this script sets up its own)" >&2
    exit 2
fi
state=$work/slurm
rm -rf "$work"
mkdir -p "$state/ctld" "$state/spool" "$work/logs"
node_line=$(slurmd -C | head -1)
node=$(printf '%s\n' "$node_line" | sed -n 's/^NodeName=\([^ ]*\).*/\1/p')
export SLURM_CONF=$state/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=mapkeeper
SlurmctldHost=$node
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
MinJobAge=3600
$node_line State=UNKNOWN
PartitionName=main Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
stop_daemons() {
    for d in slurmd slurmctld; do
        if [ -s "$state/$d.pid" ]; then
            kill "$(cat "$state/$d.pid")" 2>/dev/null || true
        fi
    done
}
if [ "${KEEP_SLURM:-0}" != 1 ]; then
    trap stop_daemons EXIT
fi
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
    if sinfo -h -N -o '%T' 2>/dev/null | grep -qx idle; then break; fi
    sleep 1
done
say "node: $(sinfo -h -N -o '%N %T, %c CPUs, %m MB')"

# 5. The recipe: the array, then the merge once every task succeeded.
cd "$work"
array=$(OUT=$work/sweep SHARDS=$shards VALIDATE_ARGS=$args MAPKEEPER=$bin \
    sbatch --parsable --array="1-$shards" --output="$work/logs/task-%A_%a.log" \
    "$repo/docs/scale-out/slurm-array.sh")
list=$(for k in $(seq 1 "$shards"); do printf ' %q' "$work/sweep/shards/$k"; done)
merge=$(sbatch --parsable --dependency="afterok:$array" --job-name=mapkeeper-merge \
    --output="$work/logs/merge-%j.log" --wrap "$(printf '%q' "$bin") merge$list --out $(printf '%q' "$work/sweep/all") --force")
say "submitted array $array (tasks 1-$shards: validate $args) and merge $merge (afterok:$array)"
start=$SECONDS
while squeue -h -j "$array,$merge" 2>/dev/null | grep -q .; do
    sleep 2
done
say "both done after $((SECONDS - start)) s"
failed=0
for j in "$array" "$merge"; do
    while read -r line; do
        id=$(printf '%s\n' "$line" | grep -o 'JobId=[^ ]*' | head -1)
        st=$(printf '%s\n' "$line" | grep -o 'JobState=[^ ]*')
        task=$(printf '%s\n' "$line" | grep -o 'ArrayTaskId=[^ ]*' || true)
        ex=$(printf '%s\n' "$line" | grep -o 'ExitCode=[^ ]*' | head -1)
        say "  $id ${task:+$task }$st $ex"
        [ "$st" = JobState=COMPLETED ] || failed=1
    done < <(scontrol -o show job "$j")
done
for f in "$work"/logs/*.log; do
    say "  $(basename "$f"): $(grep -E '^(validate: [0-9]+ seed|wrote .*summary|merge)' "$f" | tail -1)"
done
if [ "$failed" != 0 ]; then
    say "a job did not complete (logs above; daemons' logs in $state)"
    exit 1
fi

# 6. The same sweep unsharded, and the comparison.
read -r -a sweep <<<"$args"
"$bin" validate "${sweep[@]}" --jobs 2 --out "$work/single" --force >"$work/logs/single.out" 2>&1
n_files=$(find "$work/single" -type f | wc -l)
if diff -r "$work/single" "$work/sweep/all" >"$work/diff.txt"; then
    say "merged folder = unsharded run: $n_files files, identical (diff -r)"
else
    say "merged folder differs from the unsharded run:"
    head -40 "$work/diff.txt"
    exit 1
fi
