#!/usr/bin/env bash
# docs/hardening.md, "Issue 32 part A": the second hostile pass over the dataset sweep's merge,
# ledgers, manifests, shard specs, Slurm variables, generate-parts and deploy scripts. One
# Markdown row per case: exit code, seconds, peak MB, the start of stderr (or of stdout), and
# what the case left behind. Needs python3 (to tamper with JSON).
#
#   benches/hardening/issue32.sh PATH/TO/sdfmo LABEL [PATH/TO/deploy]
#
# A small dataset (four boxes, two shards, depth 3, 16² views) is swept once per run; each case
# works on a fresh copy of the shard folders.
set -uo pipefail
B=$(realpath "$1"); L=$2; D=$(realpath "${3:-$(dirname "$0")/../../deploy}")
W=$(mktemp -d /tmp/sdfmo-issue32.XXXXXX)
trap 'chmod -R u+w $W 2>/dev/null; rm -rf $W' EXIT
F=(--depths 3 --size 16 --frames 1 --threads 1)
row() { name=$1; note=$2; shift 2
  /usr/bin/time -f "%e %M" -o $W/t "$@" > $W/out 2> $W/err; rc=$?
  read -r secs kb < <(tail -1 $W/t)
  msg=$(grep -av '^Command' $W/err | head -c 150 | tr '\n|' '  ')
  [ -z "$msg" ] && msg="stdout: $(head -c 100 $W/out | tr '\n|' '  ')"
  echo "| $name | $L | $rc | $secs s | $((kb / 1024)) MB | $msg | $(eval "$note" 2>&1 | tr '\n|' '  ') |"
}
box() { python3 -c "
s=float('$1'); print(''.join('v %g %g %g\n'%tuple(s*((i>>b)&1) for b in range(3)) for i in range(8)), end='')
for f in [(1,3,4,2),(5,6,8,7),(1,2,6,5),(3,7,8,4),(1,5,7,3),(2,4,8,6)]: print('f %d %d %d\nf %d %d %d'%(f[0],f[1],f[2],f[0],f[2],f[3]))
" > "$2"; }
# JSON edits: jl FILE 'python on r (each ledger record of a model that succeeded)';
# js FILE 'python on v (shard.json)'.
jl() { python3 -c "
import json,sys
rs=[json.loads(l) for l in open('$1')]
for r in rs:
    if r['rows']:
        $2
open('$1','w').write(''.join(json.dumps(r)+'\n' for r in rs))"; }
js() { python3 -c "
import json
v=json.load(open('$1'))
$2
json.dump(v,open('$1','w'))"; }

mkdir -p $W/data
for s in 1 2 3 4 5; do box $s $W/data/box$s.obj; done
cp $W/data/box1.obj $W/data/a.obj; cp $W/data/box2.obj $W/data/b.obj
cp $W/data/box3.obj $W/data/c.obj; cp $W/data/box4.obj $W/data/-dash.obj
printf 'a.obj\nb.obj\nc.obj\n-dash.obj\n' > $W/data/m.txt
for k in 0 1; do $B sweep --manifest $W/data/m.txt --shard $k/2 "${F[@]}" -o $W/base/shard-$k > /dev/null 2>&1; done
fresh() { rm -rf $W/c; mkdir -p $W/c; cp -a $W/base/shard-0 $W/base/shard-1 $W/c/; cp -a $W/data $W/c/data; }
M=(sweep --merge $W/c/shard-0 $W/c/shard-1)
S0=$W/c/shard-0; S1=$W/c/shard-1
# ledger_row NAME 'python on r': a case that only edits shard-1's ledger (see jl) and merges.
ledger_row() { fresh; jl $S1/ledger.jsonl "$2"; row "$1" "true" $B "${M[@]}" -o $W/c/r; }

echo "| case | binary | exit | time | peak | stderr | afterwards |"
echo "|---|---|---|---|---|---|---|"
fresh
row "base run: 4 models (one named -dash), merge" "python3 -c \"import json;print(len(json.load(open('$W/c/r/results.json'))['models']),'models')\"" $B "${M[@]}" -o $W/c/r
fresh; jl $S1/ledger.jsonl "r['name']='../../escape' if r['id']=='b.obj' else r['name']; r['model']['model']=r['name']; [x.__setitem__('model',r['name']) for x in r['rows']]"
row "ledger model name ../../escape" "find $W -name escape | sed 's|$W|W|' | head -1" $B "${M[@]}" -o $W/c/deep/r
fresh; jl $S1/ledger.jsonl "r['name']='/tmp/sdfmo-i32-abs' if r['id']=='b.obj' else r['name']; r['model']['model']=r['name']; [x.__setitem__('model',r['name']) for x in r['rows']]"
row "ledger model name /tmp/… (absolute)" "ls -d /tmp/sdfmo-i32-abs 2>&1; rm -rf /tmp/sdfmo-i32-abs" $B "${M[@]}" -o $W/c/r
fresh; for k in 0 1; do js $W/c/shard-$k/shard.json "v['settings']['methods']=['svo','../../m']"; done
row "shard.json method ../../m" "ls $W/c | tr '\n' ' '" $B "${M[@]}" -o $W/c/r
fresh; echo "private" > $W/secret; chmod 600 $W/secret; rm $S0/images/a/svo_d3_0.png; ln -s $W/secret $S0/images/a/svo_d3_0.png
row "image → link to a 0600 file" "stat -c '%a %s' $W/c/r/images/a/svo_d3_0.png 2>&1 | head -c 60" $B "${M[@]}" -o $W/c/r
fresh; mv $S0/images $W/c/moved; ln -s $W/c/moved $S0/images
row "images/ → link to a folder" "ls $W/c/r/images 2>&1 | head -c 40" $B "${M[@]}" -o $W/c/r
fresh; mv $S0/ledger.jsonl $W/c/moved.jsonl; ln -s $W/c/moved.jsonl $S0/ledger.jsonl
row "ledger.jsonl → link" "true" $B "${M[@]}" -o $W/c/r
fresh; mv $S0/shard.json $W/c/moved.json; ln -s $W/c/moved.json $S0/shard.json
row "shard.json → link" "true" $B "${M[@]}" -o $W/c/r
fresh; rm $S0/shard.json; mkfifo $S0/shard.json
row "shard.json is a FIFO" "true" timeout 10 $B "${M[@]}" -o $W/c/r
fresh; truncate -s 5G $S0/ledger.jsonl
row "ledger.jsonl sparse 5 GiB" "true" $B "${M[@]}" -o $W/c/r
fresh; truncate -s 1G $S0/shard.json
row "shard.json sparse 1 GiB" "true" $B "${M[@]}" -o $W/c/r
fresh; cp $S0/ledger.jsonl $W/c/victim; printf '{"torn":' >> $W/c/victim; rm $S0/ledger.jsonl; ln $W/c/victim $S0/ledger.jsonl; sum0=$(md5sum < $W/c/victim)
row "shard rerun, ledger hard-linked to a file with a torn line" "[ \"\$(md5sum < $W/c/victim)\" = \"$sum0\" ] && echo victim intact || echo victim CHANGED" $B sweep --manifest $W/c/data/m.txt --shard 0/2 "${F[@]}" -o $S0
fresh; js $S1/shard.json "v['shard']['count']=0"
row "shard.json shard count 0" "true" $B "${M[@]}" -o $W/c/r
fresh; for k in 0 1; do js $W/c/shard-$k/shard.json "v['manifest_entries']=1"; done
row "shard.json manifest_entries 1 (4 records)" "true" $B "${M[@]}" -o $W/c/r
ledger_row "row depth 255" "r['rows'][0]['depth']=255"
ledger_row "row FLIP −0.5" "r['rows'][0]['flip']=-0.5"
ledger_row "row PSNR 1e300" "r['rows'][0]['psnr']=1e300"
ledger_row "record wall_ms −5" "r['wall_ms']=-5"
ledger_row "row bytes 0" "r['rows'][0]['bytes']=0"
ledger_row "two records named a (ids differ)" "r['name']='a' if r['id']=='b.obj' else r['name']; r['model']['model']=r['name']; [x.__setitem__('model',r['name']) for x in r['rows']]"
fresh; jl $S1/ledger.jsonl "r['error']='<script>alert(1)</script>'; r['model']=None; r['rows']=[]"
row "failure text <script>" "grep -c '<script>' $W/c/r/index.html" $B "${M[@]}" -o $W/c/r
fresh; sum0=$(cat $S0/results.json | md5sum)
row "-o shard-0 (an input folder)" "[ \"\$(md5sum < $S0/results.json)\" = \"$sum0\" ] && echo shard-0 intact || echo shard-0 OVERWRITTEN" $B "${M[@]}" -o $S0
fresh
row "-o shard-0/images/../report" "ls $S0 | tr '\n' ' '" $B "${M[@]}" -o $S0/images/../report
ledger_row "record of b with index 5" "r['index'] = 5 if r['id']=='b.obj' else r['index']"
fresh; head -1 $S0/ledger.jsonl >> $S1/ledger.jsonl
row "shard-0's record appended to shard-1's ledger" "true" $B "${M[@]}" -o $W/c/r
ledger_row "ledger records of the old layout (version 1)" "r['ledger']=1"
fresh; printf 'b.obj\na.obj\nc.obj\n-dash.obj\n' > $W/c/data/m.txt
for k in 0 1; do $B sweep --manifest $W/c/data/m.txt --shard $k/2 "${F[@]}" -o $W/c/shard-$k > /dev/null 2>&1; done
row "manifest reordered, both shards rerun, merge" "true" $B "${M[@]}" -o $W/c/r
fresh; printf 'id,path\na,a.obj\nb,b.obj\n' > $W/c/data/m.csv
for k in 0 1; do $B sweep --manifest $W/c/data/m.csv --shard $k/2 "${F[@]}" -o $W/c/e$k > /dev/null 2>&1; done
printf 'id,path\na,a.obj\nb,box5.obj\n' > $W/c/data/m.csv
for k in 0 1; do $B sweep --manifest $W/c/data/m.csv --shard $k/2 "${F[@]}" -o $W/c/e$k > /dev/null 2>&1; done
row "CSV id b edited to another file, both shards rerun, merge" "python3 -c \"import json;print([m['source'].split('/')[-1] for m in json.load(open('$W/c/r/results.json'))['models']])\"" $B sweep --merge $W/c/e0 $W/c/e1 -o $W/c/r
fresh; printf 'id,path\nx,a.obj\ny,b.obj\nx,c.obj\n' > $W/c/data/dup.csv
row "manifest with id x twice" "true" $B sweep --manifest $W/c/data/dup.csv "${F[@]}" -o $W/c/dup
fresh; cp $W/data/a.obj $W/c/data/--help.obj; printf -- '--help.obj\n' > $W/c/data/h.txt
row "model file --help.obj" "true" $B sweep --manifest $W/c/data/h.txt "${F[@]}" -o $W/c/h
row "--shard 0/0" "true" $B sweep --manifest $W/data/m.txt --shard 0/0 -o $W/c/x
row "SLURM_ARRAY_TASK_ID 2^64−1 of 1" "true" env SLURM_ARRAY_TASK_ID=18446744073709551615 SLURM_ARRAY_TASK_COUNT=1 $B sweep --manifest $W/data/m.txt -o $W/c/x
row "SLURM_ARRAY_TASK_COUNT 0" "true" env SLURM_ARRAY_TASK_ID=0 SLURM_ARRAY_TASK_COUNT=0 $B sweep --manifest $W/data/m.txt -o $W/c/x
row "SLURM_ARRAY_TASK_MIN above the id" "true" env SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MIN=5 SLURM_ARRAY_TASK_COUNT=4 $B sweep --manifest $W/data/m.txt -o $W/c/x
row "SDFMO_SHARD_COUNT -1" "true" env JOB_COMPLETION_INDEX=0 SDFMO_SHARD_COUNT=-1 $B sweep --manifest $W/data/m.txt -o $W/c/x
row "generate-parts --first 2^64−1 -n 2" "ls $W/c/gp 2>&1 | head -c 60" $B generate-parts --first 18446744073709551615 -n 2 -o $W/c/gp
row "generate-parts --first 2^64−3 -n 2" "ls $W/c/gp2 | tr '\n' ' '" $B generate-parts --first 18446744073709551613 -n 2 -o $W/c/gp2
# Deploy: submit.sh against a stub sbatch.
mkdir -p $W/bin; printf '#!/bin/sh\necho "$*" >> %s/calls\necho 42\n' $W > $W/bin/sbatch; chmod +x $W/bin/sbatch
row "submit.sh SHARDS='HOME[\$(touch PWNED)]'" "ls $W/PWNED 2>/dev/null || echo no PWNED; rm -f $W/PWNED $W/calls" env PATH=$W/bin:$PATH bash -c "cd $W && bash $D/slurm/submit.sh $W/data/m.txt $W/root 'HOME[\$(touch PWNED)]'"
row "submit.sh SHARDS=0" "cat $W/calls 2>/dev/null | head -1 | cut -c1-60 || true; rm -f $W/calls" env PATH=$W/bin:$PATH bash $D/slurm/submit.sh $W/data/m.txt $W/root 0
row "submit.sh SDFMO_CPUS_PER_TASK='\$(id)'" "rm -f $W/calls" env PATH=$W/bin:$PATH SDFMO_CPUS_PER_TASK='$(id)' bash $D/slurm/submit.sh $W/data/m.txt $W/root 4
# The memory cap under a lower hard limit, as a user without CAP_SYS_RESOURCE.
printf 'a.obj\n' > $W/data/one.txt
row "shard under a hard RLIMIT_AS of 8 GiB, no CAP_SYS_RESOURCE" "true" setpriv --bounding-set=-sys_resource prlimit --as=8589934592 $B sweep --manifest $W/data/one.txt "${F[@]}" -o $W/c/mem
