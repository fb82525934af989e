# Generates the inputs of docs/hardening.md, "Issue 19", in the current folder:
# python3 benches/hardening/gen.py (run inside an empty scratch folder).
import struct, json, os
# doubling glTF, 18 levels
pos=[]; idx=[]
for k in range(130): pos += [float(k), float(k%2), 0.0]
for k in range(128): idx += [k,k+1,k+2]
bin_ = struct.pack('<%df'%len(pos), *pos); pl=len(bin_)
bin_ += struct.pack('<%dI'%len(idx), *idx)
open('doubling.bin','wb').write(bin_)
nodes=[{"mesh":0}]+[{"children":[l-1,l-1],"translation":[0,l,0]} for l in range(1,19)]
doc={"asset":{"version":"2.0"},"buffers":[{"uri":"doubling.bin","byteLength":len(bin_)}],
"bufferViews":[{"buffer":0,"byteLength":pl},{"buffer":0,"byteOffset":pl,"byteLength":len(bin_)-pl}],
"accessors":[{"bufferView":0,"componentType":5126,"count":130,"type":"VEC3","min":[0,0,0],"max":[129,1,0]},
{"bufferView":1,"componentType":5125,"count":384,"type":"SCALAR"}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
"nodes":nodes,"scenes":[{"nodes":[18]}],"scene":0}
open('doubling.gltf','w').write(json.dumps(doc))
# tiny cube as ASCII OBJ
s=2.5e-12
v=[(x,y,z) for x in (-s,s) for y in (-s,s) for z in (-s,s)]
f=[(0,1,3),(0,3,2),(4,7,5),(4,6,7),(0,4,5),(0,5,1),(2,3,7),(2,7,6),(0,2,6),(0,6,4),(1,5,7),(1,7,3)]
open('tiny.obj','w').write(''.join(f"v {a:e} {b:e} {c:e}\n" for a,b,c in v)+''.join(f"f {a+1} {b+1} {c+1}\n" for a,b,c in f))
open('cube.obj','w').write(''.join(f"v {a*2e11} {b*2e11} {c*2e11}\n" for a,b,c in v)+''.join(f"f {a+1} {b+1} {c+1}\n" for a,b,c in f))
open('far.xyz','w').write("1e20 0 0\n")
with open('nul.xyz','wb') as fh: fh.write(b'\0'*(100<<20))
# empty accessor with a huge offset
tri=struct.pack('<9f',0,0,0,1,0,0,0,1,0)
open('tri.bin','wb').write(tri)
g={"asset":{"version":"2.0"},"buffers":[{"uri":"tri.bin","byteLength":36}],"bufferViews":[{"buffer":0,"byteOffset":4,"byteLength":32}],
"accessors":[{"bufferView":0,"byteOffset":18446744073709551615,"componentType":5126,"count":0,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}
open('empty_acc.gltf','w').write(json.dumps(g))
# Fan-capped cylinders (caps fanned from a rim vertex, as CAD exporters write them), a 600-gon
# capped cylinder in OBJ, a single 50 000-triangle fan, and 10 000 query points.
import math, random
def cyl(n, path, r=1.0, h=0.5):
    with open(path,'w') as f:
        for y in (-h/2, h/2):
            for k in range(n):
                a=2*math.pi*k/n; f.write(f"v {r*math.cos(a)} {y} {r*math.sin(a)}\n")
        for k in range(n):
            k1=(k+1)%n
            f.write(f"f {k+1} {k+n+1} {k1+1}\nf {k1+1} {k+n+1} {k1+n+1}\n")
        for k in range(1,n-1):
            f.write(f"f 1 {k+1} {k+2}\nf {n+1} {n+k+2} {n+k+1}\n")
def ngon(n, path):
    with open(path,'w') as f:
        for y in (-0.25, 0.25):
            for k in range(n):
                a=2*math.pi*k/n; f.write(f"v {math.cos(a)} {y} {math.sin(a)}\n")
        for k in range(n):
            k1=(k+1)%n
            f.write(f"f {k+1} {k+n+1} {k1+1}\nf {k1+1} {k+n+1} {k1+n+1}\n")
        f.write("f "+" ".join(str(k+1) for k in range(n))+"\n")
        f.write("f "+" ".join(str(n+k+1) for k in reversed(range(n)))+"\n")
def fan(n, path):
    with open(path,'w') as f:
        f.write("v 0 0 0\n")
        for k in range(n):
            a=2*math.pi*k/n; f.write(f"v {math.cos(a)} {math.sin(a)} 0\n")
        for k in range(n):
            f.write(f"f 1 {k+2} {(k+1)%n+2}\n")
for n in (600, 5000, 50000): cyl(n, f"fan_cyl_{n}.obj")
ngon(600, "ngon_600.obj")
fan(50000, "fan_50000.obj")
random.seed(1)
open('pts.xyz','w').write(''.join(f'{random.uniform(-1.2,1.2)} {random.uniform(-1.2,1.2)} {random.uniform(-1.2,1.2)}\n' for _ in range(10000)))
