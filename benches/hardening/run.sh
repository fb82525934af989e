#!/usr/bin/env bash
# docs/hardening.md, "Issue 19": one Markdown row per case (exit, seconds, peak MB, stderr bytes,
# the start of stderr). Run inside the folder gen.py filled: run.sh PATH/TO/sdfmo LABEL
B=$(realpath "$1"); L=$2; H=$PWD; C=$PWD; W=$(mktemp -d)
row() { name=$1; shift
  /usr/bin/time -f "%e %M" -o $W/t "$@" > $W/out 2> $W/err; rc=$?
  read secs kb < <(tail -1 $W/t)
  echo "| $name | $L | $rc | $secs s | $((kb/1024)) MB | $(stat -c %s $W/err) B | $(grep -av '^Command' $W/err | head -c 110 | tr '\n|' '  ') |"
}
row "fan cylinder 600, build d8" $B build $H/fan_cyl_600.obj -d 8 -o $W/a.smo
row "600-gon cylinder (OBJ), build d8" $B build $H/ngon_600.obj -d 8 -o $W/b.smo
row "fan cylinder 5000, build d8" $B build $H/fan_cyl_5000.obj -d 8 -o $W/c.smo
row "fan cylinder 600, distance 10k pts" $B distance $H/fan_cyl_600.obj --points $H/pts.xyz -o $W/d.txt
row "fan cylinder 600, render-mesh paper 1024²" $B render-mesh $H/fan_cyl_600.obj --views paper -o $W/rm.png
row "100 MB NUL points line" $B distance $C/cube.obj --points $C/nul.xyz
row "point at 1e20" $B distance $C/cube.obj --points $C/far.xyz
row "doubling glTF (1.4 KB + 3 KB), info" $B info $C/doubling.gltf
row "doubling glTF, build d6" $B build $C/doubling.gltf -d 6 -o $W/e.smo
row "5e-12 m cube, build d6" $B build $C/tiny.obj -d 6 -o $W/f.smo
row "empty accessor, offset 2^64-1, info" $B info $C/empty_acc.gltf
# links planted at derived names
mkdir -p $W/sw/images; echo precious > $W/victim
for f in results.csv index.html; do ln -s $W/victim $W/sw/$f; done
row "sweep with links at results.csv, index.html" $B sweep --depths 4..4 --size 64 -o $W/sw
echo "| (victim after the sweep) | $L | | | | | $(head -c 40 $W/victim | tr '\n|' '  ') |"
echo precious > $W/victim; mkdir -p $W/rv; ln -s $W/victim $W/rv/out_2.png
$B build -d 5 -o $W/demo.smo > /dev/null 2>&1
row "render --views paper -o rv/out.png, link at out_2.png" $B render $W/demo.smo --views paper --size 64 -o $W/rv/out.png
echo "| (victim after the render) | $L | | | | | $(head -c 40 $W/victim | tr '\n|' '  ') |"
rm -rf $W
