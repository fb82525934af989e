#!/usr/bin/env bash
# Instructions (callgrind, one thread) of two sdfmo CLIs on the same work, and whether their
# outputs are byte-identical: `build` of teapot and abc5 at depth 8 (multi), then `render
# --views paper --size 512` of the OLD CLI's octree by each. For a refactor that must not change
# output or cost (issue 36: octrees and images byte-identical, instructions within 1 %).
#
#   benches/cli_icount.sh OLD/sdfmo NEW/sdfmo > docs/results/build/cli-icount.txt
set -euo pipefail
OLD=$(realpath "$1") NEW=$(realpath "$2")
DATA=$(realpath "${SDFMO_TEST_DATA:-$(dirname "$0")/../../shared/data}")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
count() { valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>&1 >/dev/null |
  grep -o 'Collected : [0-9]*' | grep -o '[0-9]*'; }
echo "| work | old instructions | new instructions | new ÷ old | outputs |"
echo "|---|---:|---:|---:|---|"
for model in teapot.obj abc5.stl; do
  stem=${model%.*}
  o=$(count "$OLD" build "$DATA/$model" -d 8 --method multi --threads 1 -o "old-$stem.smo")
  n=$(count "$NEW" build "$DATA/$model" -d 8 --method multi --threads 1 -o "new-$stem.smo")
  same=$(cmp -s "old-$stem.smo" "new-$stem.smo" && echo identical || echo DIFFERENT)
  echo "| build $stem depth 8 multi | $o | $n | $(python3 -c "print(f'{$n/$o:.4f}')") | $same |"
done
for model in teapot abc5; do
  o=$(count "$OLD" render "old-$model.smo" --views paper --size 512 --threads 1 -o "old-$model.png")
  n=$(count "$NEW" render "old-$model.smo" --views paper --size 512 --threads 1 -o "new-$model.png")
  same=identical
  for k in 0 1 2 3; do cmp -s "old-${model}_$k.png" "new-${model}_$k.png" || same=DIFFERENT; done
  echo "| render $model, 4 paper views, 512² | $o | $n | $(python3 -c "print(f'{$n/$o:.4f}')") | $same (4 PNGs) |"
done
