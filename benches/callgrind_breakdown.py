#!/usr/bin/env python3
"""Per-frame instruction breakdown of a callgrind profile (docs/results/render.md, issue 13).

    valgrind --tool=callgrind --callgrind-out-file=OUT \
        target/release/examples/cpu_frame --threads 1 --repeat 1 abc1.smo
    benches/callgrind_breakdown.py OUT new      # `old` for profiles of code before 9e9ad42

Two renders per profile (the first render and one repeat), so counts are halved; loading and
validating the file is left out. Categories by the source file of each line (inlined lines keep
theirs), the function they are inlined in, and for ray_voxel.rs by line range (`new`: the file
from 66a925b on, `old`: before it). Approximate: inlined std/glam/intrinsic lines have no file of
ours and are counted with the function they sit in (the traversal, where the kernel is inlined
into it).
"""
import re, subprocess, sys, collections
out = sys.argv[1]; frames = 2
NEW = len(sys.argv) > 2 and sys.argv[2] == 'new'
txt = subprocess.run(['callgrind_annotate', out], capture_output=True, text=True).stdout
cat = collections.Counter()
tot = 0
for line in txt.split('Auto-annotated source')[0].splitlines():
    m = re.match(r'\s*([\d,]+) \([ \d.]+%\)\s+(\S+?):(.*)$', line)
    if not m: continue
    n = int(m.group(1).replace(',', '')); f = m.group(2); fn = m.group(3)
    if 'PROGRAM TOTALS' in line: continue
    tot += n
    if any(k in f for k in ('crc32', 'validate')) or 'validate' in fn or 'crc32' in fn or 'load' in fn and 'octree' in f:
        c = 'load (not per frame)'
    elif 'ray_voxel.rs' in f:
        c = 'KERNEL'  # split by lines below
    elif 'normal.rs' in f or 'hit_normal' in fn or 'shading.rs' in f or 'trilinear_gradient' in fn:
        c = 'normal + shading'
    elif 'interpolant.rs' in f:
        c = 'kernel: cubic set-up' if ('intersect' in fn or 'packet' in fn or 'call_mut' in fn) else 'normal + shading'
    elif 'voxel_corners' in fn or 'leaf_voxels' in fn:
        c = 'kernel: voxel fetch (corners)'
    elif 'traversal.rs' in f or 'packet.rs' in f or 'sdfmo-format' in f:
        c = 'traversal'
    elif 'sdfmo-render/src/octree.rs' in f:
        c = 'traversal'
    elif 'render.rs' in f or 'camera.rs' in f or 'dvec3' in f or 'rayon' in f:
        c = 'renderer (camera rays, box rejection, tiles)'
    elif ('/rustc/' in f or 'glam' in f) and 'intersect_voxel' in fn:
        c = 'kernel: std helpers (min/max, ranges)'
    elif ('/rustc/' in f or 'glam' in f) and 'hit_normal' in fn:
        c = 'normal + shading'
    elif '/rustc/' in f or 'glam' in f:
        c = 'traversal: inlined std, glam and SIMD intrinsics' if ('packet' in fn or 'call_mut' in fn or 'intersect' in fn) else 'other'
    else:
        c = 'other'
    cat[c] += n
# split kernel lines with the line-level annotation of ray_voxel.rs
ann = subprocess.run(['callgrind_annotate', '--auto=yes', '--show-percs=no', out], capture_output=True, text=True).stdout
sec = ann.split('Auto-annotated source: ')
kl = collections.Counter()
for s in sec:
    if 'sdfmo-trace/src/ray_voxel.rs' not in s.splitlines()[0]: continue
    ln = 0
    for line in s.splitlines()[1:]:
        m = re.match(r'\s*([\d,.]+)\s{2,}(.*)$', line)
        m2 = re.match(r'\s*\.\s{2,}(.*)$', line)
        if line.startswith('-- line'):
            mm = re.search(r'line (\d+)', line); ln = int(mm.group(1)) - 1; continue
        if m and not line.strip().startswith('=>'):
            ln += 1; n = int(m.group(1).replace(',', '')) if m.group(1) != '.' else 0
            if NEW:
                if 57 <= ln <= 84 or ln == 229: k = 'kernel: cubic set-up'
                elif 161 <= ln <= 228 or 314 <= ln <= 324: k = 'kernel: early-outs, normalisation'
                else: k = 'kernel: root isolation'
            else:
                if 57 <= ln <= 84 or ln == 194: k = 'kernel: cubic set-up'
                elif 161 <= ln <= 196 or 278 <= ln <= 288: k = 'kernel: early-outs, normalisation'
                else: k = 'kernel: root isolation'
            kl[k] += n
        elif m2:
            ln += 1
kt = sum(kl.values()); kfile = cat.pop('KERNEL', 0)
if not kt:
    kl['kernel (ray_voxel.rs; sources not found for a split)'] = 1; kt = 1
for k, v in kl.items():
    cat[k] += v * kfile / kt if kt else 0
per = {k: v / frames / 1e6 for k, v in cat.items()}
total = sum(v for k, v in per.items() if not k.startswith('load'))
print('| part | M instructions / frame | share |'); print('|---|---|---|')
for k, v in sorted(per.items(), key=lambda x: -x[1]):
    if k.startswith('load'): continue
    print(f'| {k} | {v:.1f} | {100*v/total:.0f} % |')
print(f'| **total per frame** | **{total:.1f}** | |')
