#!/usr/bin/env bash
# Local scale-out of `mapkeeper validate`: N shards as separate processes, P at a time
# (xargs -P), each into OUT/shards/k, then `mapkeeper merge` into OUT/all.
#
#   docs/scale-out/local-shards.sh N P OUT [validate arguments…]
#   e.g. docs/scale-out/local-shards.sh 4 2 sweep --presets paper,mapkeeper --seeds 8
#
# Each shard runs with --jobs 1 (the parallelism is the P processes) and --resume. A shard whose
# folder is complete (it has runs.json: folders appear whole or not at all) is skipped, so
# re-running the same command after a kill runs only the shards that did not finish, and within
# a killed shard only the (preset, seed) jobs it had not finished (their checkpoints are in
# `.k.jobs`); a killed shard's `.k.partial` staging folder is reported and removed by its
# re-run. Do not pass --force (it would defeat the resume). OUT/recipe.txt records N and
# the validate arguments: a re-run with other ones is refused (it would mix shards of two
# sweeps). OUT/all is rewritten by every run. Set MAPKEEPER to the binary (default: `mapkeeper`
# on PATH).
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 N P OUT [validate arguments…]" >&2
    exit 2
fi
n=$1 p=$2 out=$3
shift 3
for v in "$n" "$p"; do
    case "$v" in
        *[!0-9]* | '' | 0*) echo "$0: N and P must be whole numbers ≥ 1, got N = '$n', P = '$p'" >&2; exit 2 ;;
    esac
done
for a in "$@"; do
    if [ "$a" = "--force" ]; then
        echo "$0: drop --force: shards resume what a killed run finished (--resume)" >&2
        exit 2
    fi
done
bin=${MAPKEEPER:-mapkeeper}
mkdir -p "$out/shards"
stamp=$(printf 'N=%s' "$n"; printf ' %q' "$@")
if [ -f "$out/recipe.txt" ] && [ "$(cat "$out/recipe.txt")" != "$stamp" ]; then
    echo "$0: $out holds shards of another sweep ($(cat "$out/recipe.txt")), not of ($stamp): use another OUT" >&2
    exit 2
fi
printf '%s' "$stamp" >"$out/recipe.txt"
todo=()
for k in $(seq 1 "$n"); do
    if [ -f "$out/shards/$k/runs.json" ] || [ -f "$out/shards/$k/summary.json" ]; then
        echo "shard $k/$n: complete, skipped"
    else
        todo+=("$k")
    fi
done
if [ ${#todo[@]} -gt 0 ]; then
    printf '%s\n' "${todo[@]}" |
        xargs -P "$p" -I{} "$bin" validate "$@" --shard "{}/$n" --jobs 1 --resume --out "$out/shards/{}"
fi
shards=()
for k in $(seq 1 "$n"); do shards+=("$out/shards/$k"); done
"$bin" merge "${shards[@]}" --out "$out/all" --force
