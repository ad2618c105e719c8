#!/usr/bin/env bash
# Runs a study as a Slurm job array of N shards and merges them:
#
#   scripts/slurm-study.sh STUDY OUT N [aeroid study options…]
#
# Shard K writes OUT/shard-K (a journal: a re-submitted task resumes it);
# when every task has finished, the shards are merged into OUT/merged,
# byte-identical to a one-machine run. The aeroid binary is $AEROID, else
# `aeroid` on the PATH; sbatch options (partition, time, account) go in
# $SBATCH_OPTIONS. Every node must see OUT and the study's files.
set -euo pipefail

if [ $# -lt 3 ]; then
    echo "usage: $0 STUDY OUT SHARDS [aeroid study options…]" >&2
    exit 2
fi
study=$1
out=$2
shards=$3
shift 3
case $shards in
    ''|*[!0-9]*|0) echo "$0: SHARDS must be a positive integer, not '$shards'" >&2; exit 2 ;;
esac
aeroid=${AEROID:-$(command -v aeroid || true)}
[ -n "$aeroid" ] || { echo "$0: aeroid not found: set AEROID=/path/to/aeroid" >&2; exit 1; }
aeroid=$(realpath "$aeroid")
mkdir -p "$out/logs"
out=$(realpath "$out")

# One task per shard; each resumes its journal if it is there already.
# shellcheck disable=SC2086
sbatch --wait --array="1-$shards" ${SBATCH_OPTIONS:-} \
    --job-name="aeroid-$(basename "$study" .toml)" \
    --output="$out/logs/shard-%a.log" \
    --cpus-per-task="${CPUS_PER_TASK:-1}" \
    --wrap="shard=\$SLURM_ARRAY_TASK_ID; resume=; [ -f '$out'/shard-\$shard/cases.jsonl ] && resume=--resume; '$aeroid' study '$study' --out '$out'/shard-\$shard --shard \$shard/$shards --threads \${SLURM_CPUS_PER_TASK:-1} \$resume $*"

folders=()
for k in $(seq 1 "$shards"); do
    folders+=("$out/shard-$k")
done
"$aeroid" study merge --out "$out/merged" "${folders[@]}"
