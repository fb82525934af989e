// OpenVDB / NanoVDB peer of sdf-multioctree (issue 33). Built by benches/peers/openvdb/setup.sh
// with g++ against Debian's libopenvdb-dev / libnanovdb-dev 10.0.1; nothing in the Rust
// workspace depends on it.
//
//   vdbpeer build MESH --depth D --band B --out DIR [--threads N]
//       The mesh is loaded (binary/ASCII STL or OBJ), bit-identical vertices welded, and
//       normalised exactly as sdfmo-build does (crates/sdfmo-mesh/src/mesh.rs,
//       Normalization::for_bounds with margin 0.05, in f32: centre of the bounding box to the
//       origin, longest extent to 2(1 - 0.05)); then openvdb::tools::meshToLevelSet with a
//       linear transform of voxel size 2/2^D (index point (i,j,k) = world (i,j,k)·h, so the
//       lattice is the octree's corner lattice) and half-width B voxels. Writes DIR/band{B}.vdb
//       (openvdb::io::File, default compression) and the NanoVDB grids DIR/band{B}_{float,fp16,
//       fp8,fp4,fpn}.nvdb (nanovdb::io::writeGrid, no codec), and prints one JSON object:
//       timings (wall and CPU), active voxels, bytes of each file and each in-memory grid.
//       --unsigned ISO: meshToUnsignedDistanceField minus ISO voxels instead (OpenVDB's tool for
//       open meshes: the zero set is a shell ISO voxels each side of every surface); files uband{B}*.
//       --shift: index (0,0,0) at world (-1,-1,-1) (same lattice; the cube in one upper internal
//       node, not the 8 around the index origin); files sband{B}*.
//   vdbpeer render GRID.nvdb --out PREFIX [--views 0,1,2,3] [--size N] [--threads N]
//       [--frames K] [--zc | --raw]
//       The paper protocol (crates/sdfmo-render: camera.rs, shading.rs): eye 3(sin θ,0,cos θ),
//       θ = 2πk/4, target origin, +Y up, fov 60°, pixel centres, frame in f64 and each ray
//       direction rounded to f32 once; lambert: round(clamp(0.25 + 2/3·max(0, n·l), 0, 1)·255),
//       l = normalize(1,1,1), normals flipped to face the viewer, black background, 8-bit grey
//       RGB. Hits (default, "exact"): NanoVDB's HDDA (nanovdb::firstActive) skips empty space to
//       the narrow band, then the ray walks the trilinear cells and solves the interpolant along
//       it exactly per cell (see trace_exact); the normal is the trilinear gradient. --zc:
//       nanovdb::ZeroCrossing, the hit refined on the trilinear interpolant near its voxel.
//       --raw: nanovdb::ZeroCrossing's time and the central difference of voxel values at its
//       voxel (NanoVDB's ex_raytrace_level_set). Writes PREFIX_K.png and prints JSON (per view:
//       median wall ms and CPU ms over K frames).
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/global_control.h>

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridHandle.h>
#include <nanovdb/util/HDDA.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <nanovdb/util/Ray.h>
#include <nanovdb/util/SampleFromVoxels.h>

#include <png.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace {

struct Clock {
    std::chrono::steady_clock::time_point w0;
    double c0;
    static double cpu_s() {
        rusage ru{};
        getrusage(RUSAGE_SELF, &ru);
        return ru.ru_utime.tv_sec + ru.ru_utime.tv_usec * 1e-6 + ru.ru_stime.tv_sec + ru.ru_stime.tv_usec * 1e-6;
    }
    Clock() : w0(std::chrono::steady_clock::now()), c0(cpu_s()) {}
    double wall_ms() const { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count(); }
    double cpu_ms() const { return (cpu_s() - c0) * 1000.0; }
};

[[noreturn]] void die(const std::string& m) {
    std::cerr << "vdbpeer: " << m << std::endl;
    std::exit(2);
}

uint64_t file_bytes(const std::string& p) {
    struct stat st{};
    if (stat(p.c_str(), &st) != 0) die("cannot stat " + p);
    return uint64_t(st.st_size);
}

// ---------------------------------------------------------------- mesh loading
struct Mesh {
    std::vector<openvdb::Vec3s> pos;
    std::vector<openvdb::Vec3I> tri;
};

struct KeyHash {
    size_t operator()(const std::array<uint32_t, 3>& k) const {
        return (size_t(k[0]) * 0x9E3779B97F4A7C15ull) ^ (size_t(k[1]) * 0xC2B2AE3D27D4EB4Full) ^ k[2];
    }
};

// Welds bit-identical positions (as sdfmo-mesh's loader does for STL).
struct Welder {
    Mesh& m;
    std::unordered_map<std::array<uint32_t, 3>, uint32_t, KeyHash> index;
    explicit Welder(Mesh& mesh) : m(mesh) {}
    uint32_t add(float x, float y, float z) {
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) die("non-finite vertex");
        std::array<uint32_t, 3> k;
        x += 0.0f;  // -0 and +0 are one position (as sdfmo-mesh's welding treats them)
        y += 0.0f;
        z += 0.0f;
        std::memcpy(&k[0], &x, 4);
        std::memcpy(&k[1], &y, 4);
        std::memcpy(&k[2], &z, 4);
        auto it = index.find(k);
        if (it != index.end()) return it->second;
        uint32_t i = uint32_t(m.pos.size());
        m.pos.emplace_back(x, y, z);
        index.emplace(k, i);
        return i;
    }
};

void add_tri(Mesh& m, uint32_t a, uint32_t b, uint32_t c) {
    if (a == b || b == c || a == c) return;  // degenerate by index (dropped, as the loader does)
    m.tri.emplace_back(a, b, c);
}

Mesh load_stl(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) die("cannot open " + path);
    std::string data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    Mesh m;
    Welder w(m);
    bool binary = false;
    if (data.size() >= 84) {
        uint32_t n;
        std::memcpy(&n, data.data() + 80, 4);
        binary = (uint64_t(84) + uint64_t(n) * 50 == data.size());
    }
    if (binary) {
        uint32_t n;
        std::memcpy(&n, data.data() + 80, 4);
        for (uint32_t t = 0; t < n; ++t) {
            const char* p = data.data() + 84 + size_t(t) * 50 + 12;
            float v[9];
            std::memcpy(v, p, 36);
            add_tri(m, w.add(v[0], v[1], v[2]), w.add(v[3], v[4], v[5]), w.add(v[6], v[7], v[8]));
        }
    } else {
        std::istringstream in(data);
        std::string tok;
        std::vector<uint32_t> face;
        while (in >> tok) {
            if (tok == "vertex") {
                float x, y, z;
                in >> x >> y >> z;
                face.push_back(w.add(x, y, z));
            } else if (tok == "endloop") {
                for (size_t i = 1; i + 1 < face.size(); ++i) add_tri(m, face[0], face[i], face[i + 1]);
                face.clear();
            }
        }
    }
    return m;
}

Mesh load_obj(const std::string& path) {
    std::ifstream f(path);
    if (!f) die("cannot open " + path);
    Mesh m;
    std::vector<openvdb::Vec3s> raw;
    Welder w(m);
    std::vector<uint32_t> map;  // obj vertex -> welded index
    std::string line;
    while (std::getline(f, line)) {
        std::istringstream in(line);
        std::string tok;
        if (!(in >> tok)) continue;
        if (tok == "v") {
            float x, y, z;
            in >> x >> y >> z;
            map.push_back(w.add(x, y, z));
        } else if (tok == "f") {
            std::vector<uint32_t> face;
            std::string s;
            while (in >> s) {
                long i = std::stol(s.substr(0, s.find('/')));
                long k = i > 0 ? i - 1 : long(map.size()) + i;
                if (k < 0 || k >= long(map.size())) die("face index out of range in " + path);
                face.push_back(map[size_t(k)]);
            }
            for (size_t i = 1; i + 1 < face.size(); ++i) add_tri(m, face[0], face[i], face[i + 1]);
        }
    }
    return m;
}

Mesh load_mesh(const std::string& path) {
    std::string ext = path.substr(path.find_last_of('.') + 1);
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    Mesh m = ext == "obj" ? load_obj(path) : ext == "stl" ? load_stl(path) : (die("only .stl and .obj: " + path), Mesh{});
    // Drop zero-area triangles (the loader reports and drops them) and unreferenced vertices'
    // influence on the bounds: bounds are taken over the kept triangles' vertices.
    std::vector<openvdb::Vec3I> kept;
    kept.reserve(m.tri.size());
    for (auto& t : m.tri) {
        openvdb::Vec3d a(m.pos[t[0]]), b(m.pos[t[1]]), c(m.pos[t[2]]);
        if ((b - a).cross(c - a).lengthSqr() > 0.0) kept.push_back(t);
    }
    m.tri.swap(kept);
    if (m.tri.empty()) die("no triangles in " + path);
    return m;
}

// Normalization::for_bounds(bounds, 0.05) in f32, then to_normalized: (p - centre) · scale.
struct Norm {
    float cx, cy, cz, scale;
};

Norm normalise(Mesh& m) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    std::vector<char> used(m.pos.size(), 0);
    for (auto& t : m.tri)
        for (int k = 0; k < 3; ++k) used[t[k]] = 1;
    for (size_t i = 0; i < m.pos.size(); ++i) {
        if (!used[i]) continue;
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], m.pos[i][a]);
            hi[a] = std::max(hi[a], m.pos[i][a]);
        }
    }
    float longest = std::max(hi[0] - lo[0], std::max(hi[1] - lo[1], hi[2] - lo[2]));
    volatile float margin = 0.05f;
    float target = 2.0f * (1.0f - margin);
    float scale = (longest > 0.0f && std::isfinite(longest)) ? target / longest : 1.0f;
    Norm n{(lo[0] + hi[0]) * 0.5f, (lo[1] + hi[1]) * 0.5f, (lo[2] + hi[2]) * 0.5f, scale};
    for (auto& p : m.pos) p = openvdb::Vec3s((p[0] - n.cx) * scale, (p[1] - n.cy) * scale, (p[2] - n.cz) * scale);
    return n;
}

// ---------------------------------------------------------------- build
template <typename NanoT>
std::pair<uint64_t, double> convert(const openvdb::FloatGrid& grid, const std::string& path, double* conv_ms, float fpn_tol) {
    Clock c;
    nanovdb::OpenToNanoVDB<float, NanoT> conv;
    if constexpr (std::is_same<NanoT, nanovdb::FpN>::value) conv.oracle() = nanovdb::AbsDiff(fpn_tol);
    auto handle = conv(grid);
    *conv_ms = c.wall_ms();
    nanovdb::io::writeGrid(path + ".tmp", handle);
    std::rename((path + ".tmp").c_str(), path.c_str());
    return {handle.size(), *conv_ms};
}

int cmd_build(int argc, char** argv) {
    std::string mesh_path, out;
    int depth = -1, band = 3, threads = 2;
    double iso = -1.0;  // --unsigned ISO: meshToUnsignedDistanceField minus ISO voxels (open meshes)
    bool shift = false;  // --shift: index (0,0,0) at world (-1,-1,-1) instead of the origin
    for (int i = 2; i < argc; ++i) {
        std::string a = argv[i];
        auto next = [&]() -> std::string { if (i + 1 >= argc) die("missing value after " + a); return argv[++i]; };
        if (a == "--depth") depth = std::stoi(next());
        else if (a == "--band") band = std::stoi(next());
        else if (a == "--out") out = next();
        else if (a == "--threads") threads = std::stoi(next());
        else if (a == "--unsigned") iso = std::stod(next());
        else if (a == "--shift") shift = true;
        else if (mesh_path.empty()) mesh_path = a;
        else die("unexpected argument " + a);
    }
    if (mesh_path.empty() || out.empty() || depth < 1 || depth > 14 || band < 1) die("usage: vdbpeer build MESH --depth D --band B --out DIR [--threads N]");
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));
    openvdb::initialize();
    Clock load_clock;
    Mesh m = load_mesh(mesh_path);
    Norm n = normalise(m);
    double load_ms = load_clock.wall_ms();
    const double h = 2.0 / double(1u << depth);
    auto xform = openvdb::math::Transform::createLinearTransform(h);
    // --shift: the same lattice (world -1 + i·h), indices 0..2^D: the root cube in one upper
    // internal node (4096³ voxels) instead of the 8 that meet at index (0,0,0).
    if (shift) xform->postTranslate(openvdb::Vec3d(-1.0, -1.0, -1.0));

    Clock bc;
    openvdb::FloatGrid::Ptr grid;
    if (iso < 0.0) {
        grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, m.pos, m.tri, float(band));
    } else {
        // OpenVDB's tool for meshes that enclose nothing: the unsigned distance, then the shell
        // |d| = ISO voxels as the zero set (every surface thickened by ISO voxels on each side).
        grid = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*xform, m.pos, m.tri, {}, float(band + iso));
        const float off = float(iso * h);
        for (auto it = grid->beginValueOn(); it; ++it) it.setValue(*it - off);
        grid->tree().root().setBackground(grid->background() - off, true);
        grid->setGridClass(openvdb::GRID_LEVEL_SET);
    }
    double build_ms = bc.wall_ms(), build_cpu_ms = bc.cpu_ms();
    grid->setName("sdf");

    std::string stem = out + (iso < 0.0 ? (shift ? "/sband" : "/band") : (shift ? "/suband" : "/uband")) + std::to_string(band);
    std::string vdb = stem + ".vdb";
    Clock wc;
    {
        openvdb::io::File file(vdb + ".tmp");
        file.write({grid});
        file.close();
    }
    std::rename((vdb + ".tmp").c_str(), vdb.c_str());
    double write_ms = wc.wall_ms();

    const float fpn_tol = 0.1f * float(h);  // NanoVDB's own default for level sets (0.1 voxel)
    struct V { const char* name; uint64_t mem; double ms; };
    std::vector<V> vs;
    double ms;
    auto add = [&](const char* name, std::pair<uint64_t, double> r) { vs.push_back({name, r.first, r.second}); };
    add("float", convert<float>(*grid, stem + "_float.nvdb", &ms, fpn_tol));
    add("fp16", convert<nanovdb::Fp16>(*grid, stem + "_fp16.nvdb", &ms, fpn_tol));
    add("fp8", convert<nanovdb::Fp8>(*grid, stem + "_fp8.nvdb", &ms, fpn_tol));
    add("fp4", convert<nanovdb::Fp4>(*grid, stem + "_fp4.nvdb", &ms, fpn_tol));
    add("fpn", convert<nanovdb::FpN>(*grid, stem + "_fpn.nvdb", &ms, fpn_tol));

    std::ostringstream js;
    js.precision(10);
    js << "{\"mesh\":\"" << mesh_path << "\",\"depth\":" << depth << ",\"band\":" << band << ",\"voxel_size\":" << h
       << ",\"threads\":" << threads << ",\"unsigned_iso\":" << iso << ",\"shift\":" << (shift ? "true" : "false") << ",\"vertices\":" << m.pos.size() << ",\"triangles\":" << m.tri.size()
       << ",\"normalization\":{\"center\":[" << n.cx << "," << n.cy << "," << n.cz << "],\"scale\":" << n.scale << "}"
       << ",\"load_ms\":" << load_ms << ",\"build_ms\":" << build_ms << ",\"build_cpu_ms\":" << build_cpu_ms
       << ",\"write_vdb_ms\":" << write_ms << ",\"active_voxels\":" << grid->activeVoxelCount()
       << ",\"leaf_nodes\":" << grid->tree().leafCount() << ",\"vdb_bytes\":" << file_bytes(vdb)
       << ",\"vdb_mem_bytes\":" << grid->memUsage() << ",\"fpn_tolerance\":" << fpn_tol << ",\"nanovdb\":{";
    for (size_t i = 0; i < vs.size(); ++i) {
        js << (i ? "," : "") << "\"" << vs[i].name << "\":{\"file_bytes\":" << file_bytes(stem + "_" + vs[i].name + ".nvdb")
           << ",\"mem_bytes\":" << vs[i].mem << ",\"convert_ms\":" << vs[i].ms << "}";
    }
    js << "},\"openvdb_version\":\"" << openvdb::getLibraryVersionString() << "\"}";
    std::cout << js.str() << std::endl;
    return 0;
}

// ---------------------------------------------------------------- render
struct Frame {
    double eye[3], fwd[3], right[3], up[3], tan_half;
    int w, h;
};

void cross(const double a[3], const double b[3], double o[3]) {
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
void normd(double v[3]) {
    double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; ++i) v[i] /= l;
}

Frame paper_frame(int k, int size) {
    Frame f{};
    double th = 2.0 * M_PI * double(k % 4) / 4.0;
    float eye32[3] = {float(3.0 * std::sin(th)), 0.0f, float(3.0 * std::cos(th))};  // as_vec3: rounded to f32
    for (int i = 0; i < 3; ++i) f.eye[i] = eye32[i];
    double fwd[3] = {-f.eye[0], -f.eye[1], -f.eye[2]};
    normd(fwd);
    double up[3] = {0, 1, 0};  // never parallel to fwd for the paper views
    double right[3];
    cross(fwd, up, right);
    normd(right);
    double up2[3];
    cross(right, fwd, up2);
    std::memcpy(f.fwd, fwd, sizeof fwd);
    std::memcpy(f.right, right, sizeof right);
    std::memcpy(f.up, up2, sizeof up2);
    f.tan_half = std::tan(60.0 * M_PI / 180.0 * 0.5);
    f.w = f.h = size;
    return f;
}

template <typename BuildT>
struct Tracer {
    const nanovdb::NanoGrid<BuildT>* grid;
    float inv_h;  // world -> index scale
    float inv_h_world;  // distance values (world units) -> voxels
    int mode;  // 0 exact, 1 zero-crossing + refine, 2 raw zero-crossing
    bool raw;
    float light[3];
    bool debug_fallbacks = std::getenv("VDBPEER_DEBUG") != nullptr;

    uint8_t shade(float nx, float ny, float nz, float dx, float dy, float dz) const {
        float l = std::sqrt(nx * nx + ny * ny + nz * nz);
        if (!(l > 0.0f)) { nx = -dx; ny = -dy; nz = -dz; l = 1.0f; }
        nx /= l; ny /= l; nz /= l;
        if (nx * dx + ny * dy + nz * dz > 0.0f) { nx = -nx; ny = -ny; nz = -nz; }  // two-sided
        float direct = (2.0f / 3.0f) * std::max(0.0f, nx * light[0] + ny * light[1] + nz * light[2]);
        float v = std::min(std::max(0.25f + direct, 0.0f), 1.0f);
        return uint8_t(std::lround(v * 255.0f));
    }

    // Returns the grey value (0 = background) of one primary ray.
    template <typename AccT, typename SamplerT>
    uint8_t trace(AccT& acc, SamplerT& smp, const float o[3], const float d[3], uint64_t& fallbacks) const {
        using Vec3f = nanovdb::Vec3f;
        Vec3f io = grid->worldToIndexF(Vec3f(o[0], o[1], o[2])), id(d[0], d[1], d[2]);
        nanovdb::Ray<float> ray(io, id);
        nanovdb::Coord ijk;
        float v, t;
        if (raw) {
            if (!nanovdb::ZeroCrossing(ray, acc, ijk, v, t)) return 0;
            float gx = acc.getValue(ijk.offsetBy(1, 0, 0)) - acc.getValue(ijk.offsetBy(-1, 0, 0));
            float gy = acc.getValue(ijk.offsetBy(0, 1, 0)) - acc.getValue(ijk.offsetBy(0, -1, 0));
            float gz = acc.getValue(ijk.offsetBy(0, 0, 1)) - acc.getValue(ijk.offsetBy(0, 0, -1));
            return shade(gx, gy, gz, d[0], d[1], d[2]);
        }
        // ZeroCrossing fires at the first voxel whose (lower-corner) value has the other sign;
        // the trilinear interpolant's zero is near it but, at grazing incidence, can lie several
        // voxels further (or nowhere: the ray passes by). Refine: from 2 voxels before that voxel
        // march the interpolant with steps of max(1/8, f/2) voxels to its first sign change and
        // bisect; if the ray leaves the band (f at the background) without one, call ZeroCrossing
        // again from there.
        const float bg = grid->tree().background();
        float tmin = nanovdb::Delta<float>::value(), hit = -1.0f;
        for (int pass = 0; pass < 16 && hit < 0.0f; ++pass) {
            ray.setTimes(tmin, nanovdb::Maximum<float>::value());
            if (!nanovdb::ZeroCrossing(ray, acc, ijk, v, t)) return 0;
            float ta = std::max(tmin, t - 2.0f), fa = smp(ray(ta));
            if (fa <= 0.0f) {
                ++fallbacks;  // already inside 2 voxels before: take it
                hit = ta;
                if (debug_fallbacks) return 1;
                break;
            }
            bool left_band = false;
            for (int it = 0; it < 4096; ++it) {
                float tb = ta + std::max(0.125f, 0.5f * fa * inv_h_world);
                float fb = smp(ray(tb));
                if (fb <= 0.0f) {
                    float lo = ta, hi = tb;
                    for (int k = 0; k < 20; ++k) {
                        float mid = 0.5f * (lo + hi);
                        if (smp(ray(mid)) > 0.0f) lo = mid; else hi = mid;
                    }
                    hit = 0.5f * (lo + hi);
                    break;
                }
                ta = tb;
                fa = fb;
                if (tb > t + 2.0f && fb >= 0.999f * bg) { left_band = true; break; }
            }
            if (hit < 0.0f && !left_band) return 0;
            tmin = ta;
        }
        if (hit < 0.0f) return 0;
        auto g = smp.gradient(ray(hit));
        return shade(g[0], g[1], g[2], d[0], d[1], d[2]);
    }


    // The default intersector ("exact"): NanoVDB's HDDA (nanovdb::firstActive) skips the empty
    // space of the tree to the first active value along the ray; from one voxel before it the
    // ray walks the trilinear cells (unit cells between lattice points, 3-D DDA) and solves the
    // interpolant along the ray exactly in each cell that has corners of both signs (a cubic in
    // t: its critical points split it into monotone pieces, each bisected), as the octree's
    // kernel does per voxel. Where all 8 corners of a cell are inactive (outside the band) it
    // goes back to firstActive. Normal: the trilinear gradient at the hit.
    template <typename AccT>
    uint8_t trace_exact(AccT& acc, const float o[3], const float d[3]) const {
        using Vec3f = nanovdb::Vec3f;
        Vec3f io = grid->worldToIndexF(Vec3f(o[0], o[1], o[2])), id(d[0], d[1], d[2]);
        nanovdb::Ray<float> ray(io, id);
        float tmin = nanovdb::Delta<float>::value();
        for (int pass = 0; pass < 64; ++pass) {
            ray.setTimes(tmin, nanovdb::Maximum<float>::value());
            nanovdb::Coord first;
            float t;
            if (!nanovdb::firstActive(ray, acc, first, t)) return 0;
            // Walk cells from one voxel before the first active value.
            float tc = std::max(tmin, t - 1.5f);
            Vec3f p = ray(tc);
            int c[3] = {int(std::floor(p[0])), int(std::floor(p[1])), int(std::floor(p[2]))};
            int stp[3];
            float tnext[3], tdelta[3];
            for (int a = 0; a < 3; ++a) {
                if (d[a] > 0.0f) { stp[a] = 1; tnext[a] = tc + (float(c[a] + 1) - p[a]) / d[a]; tdelta[a] = 1.0f / d[a]; }
                else if (d[a] < 0.0f) { stp[a] = -1; tnext[a] = tc + (float(c[a]) - p[a]) / d[a]; tdelta[a] = -1.0f / d[a]; }
                else { stp[a] = 0; tnext[a] = INFINITY; tdelta[a] = INFINITY; }
            }
            float ta = tc;
            bool left = false;
            for (int it = 0; it < 100000; ++it) {
                int ax = tnext[0] < tnext[1] ? (tnext[0] < tnext[2] ? 0 : 2) : (tnext[1] < tnext[2] ? 1 : 2);
                float tb = tnext[ax];
                float v[8];
                bool any_active = false, pos = false, neg = false;
                for (int i = 0; i < 8; ++i) {
                    nanovdb::Coord q(c[0] + (i >> 2 & 1), c[1] + (i >> 1 & 1), c[2] + (i & 1));
                    v[i] = acc.getValue(q);
                    any_active |= acc.isActive(q);
                    pos |= v[i] > 0.0f;
                    neg |= v[i] <= 0.0f;
                }
                if (pos && neg) {
                    float th;
                    if (cell_root(v, c, ray, ta, tb, th)) {
                        Vec3f h = ray(th);
                        float u[3] = {h[0] - c[0], h[1] - c[1], h[2] - c[2]};
                        float g[3];
                        trilinear_grad(v, u, g);
                        return shade(g[0], g[1], g[2], d[0], d[1], d[2]);
                    }
                } else if (!any_active && ta > t + 1.0f) {
                    left = true;
                    if (neg) return 0;  // inside a negative tile: the ray started inside
                }
                if (left) { tmin = tb; break; }
                c[ax] += stp[ax];
                tnext[ax] += tdelta[ax];
                ta = tb;
                if (ta > ray.t1() + 2.0f) return 0;  // past the tree's bounding box
            }
            if (!left) return 0;
        }
        return 0;
    }

    static float trilinear(const float v[8], float x, float y, float z) {
        float a = v[0] + (v[4] - v[0]) * x, b = v[1] + (v[5] - v[1]) * x;
        float cc = v[2] + (v[6] - v[2]) * x, dd = v[3] + (v[7] - v[3]) * x;
        float e = a + (cc - a) * y, f = b + (dd - b) * y;
        return e + (f - e) * z;
    }
    static void trilinear_grad(const float v[8], const float u[3], float g[3]) {
        float x = std::min(std::max(u[0], 0.0f), 1.0f), y = std::min(std::max(u[1], 0.0f), 1.0f), z = std::min(std::max(u[2], 0.0f), 1.0f);
        auto V = [&](int i, int j, int k) { return v[4 * i + 2 * j + k]; };
        g[0] = (1 - y) * (1 - z) * (V(1, 0, 0) - V(0, 0, 0)) + y * (1 - z) * (V(1, 1, 0) - V(0, 1, 0)) + (1 - y) * z * (V(1, 0, 1) - V(0, 0, 1)) + y * z * (V(1, 1, 1) - V(0, 1, 1));
        g[1] = (1 - x) * (1 - z) * (V(0, 1, 0) - V(0, 0, 0)) + x * (1 - z) * (V(1, 1, 0) - V(1, 0, 0)) + (1 - x) * z * (V(0, 1, 1) - V(0, 0, 1)) + x * z * (V(1, 1, 1) - V(1, 0, 1));
        g[2] = (1 - x) * (1 - y) * (V(0, 0, 1) - V(0, 0, 0)) + x * (1 - y) * (V(1, 0, 1) - V(1, 0, 0)) + (1 - x) * y * (V(0, 1, 1) - V(0, 1, 0)) + x * y * (V(1, 1, 1) - V(1, 1, 0));
    }
    // First root of the interpolant along the ray in [ta, tb] (the ray inside cell c).
    static bool cell_root(const float v[8], const int c[3], const nanovdb::Ray<float>& ray, float ta, float tb, float& th) {
        auto g = [&](float t) {
            auto p = ray(t);
            return trilinear(v, p[0] - c[0], p[1] - c[1], p[2] - c[2]);
        };
        // the cubic through 4 equally spaced samples, in x = 3(t - ta)/(tb - ta) in [0, 3]
        float g0 = g(ta), g1 = g(ta + (tb - ta) / 3.0f), g2 = g(ta + 2.0f * (tb - ta) / 3.0f), g3 = g(tb);
        double d1 = g1 - g0, d2 = g2 - 2.0 * g1 + g0, d3 = g3 - 3.0 * g2 + 3.0 * g1 - g0;
        // p(x) = g0 + d1 x + d2 x(x-1)/2 + d3 x(x-1)(x-2)/6 = A x^3 + B x^2 + C x + D
        double A = d3 / 6.0, B = d2 / 2.0 - d3 / 2.0, C = d1 - d2 / 2.0 + d3 / 3.0, D = g0;
        auto P = [&](double x) { return ((A * x + B) * x + C) * x + D; };
        double xs[4] = {0.0, 0.0, 0.0, 3.0};
        int n = 1;
        // critical points: 3A x^2 + 2B x + C = 0
        double qa = 3.0 * A, qb = 2.0 * B, qc = C;
        double cr[2];
        int nc = 0;
        if (std::fabs(qa) > 1e-30) {
            double disc = qb * qb - 4.0 * qa * qc;
            if (disc >= 0.0) {
                double sq = std::sqrt(disc);
                cr[nc++] = (-qb - sq) / (2.0 * qa);
                cr[nc++] = (-qb + sq) / (2.0 * qa);
                if (cr[0] > cr[1]) std::swap(cr[0], cr[1]);
            }
        } else if (std::fabs(qb) > 1e-30) {
            cr[nc++] = -qc / qb;
        }
        for (int i = 0; i < nc; ++i)
            if (cr[i] > 0.0 && cr[i] < 3.0) xs[n++] = cr[i];
        xs[n++] = 3.0;
        for (int i = 0; i + 1 < n; ++i) {
            double lo = xs[i], hi = xs[i + 1], plo = P(lo), phi = P(hi);
            if (plo <= 0.0) { th = ta + float(lo / 3.0) * (tb - ta); return true; }
            if (phi > 0.0) continue;
            for (int k = 0; k < 30; ++k) {
                double mid = 0.5 * (lo + hi);
                if (P(mid) > 0.0) lo = mid; else hi = mid;
            }
            th = ta + float(0.5 * (lo + hi) / 3.0) * (tb - ta);
            return true;
        }
        return false;
    }

    void render(const Frame& f, int threads, std::vector<uint8_t>& rgb, uint64_t& fallbacks, uint64_t& hits) const {
        rgb.assign(size_t(f.w) * f.h * 3, 0);
        std::atomic<int> next_row{0};
        std::atomic<uint64_t> fb{0}, nh{0};
        auto worker = [&]() {
            auto acc = grid->getAccessor();
            nanovdb::SampleFromVoxels<decltype(acc), 1, true> smp(acc);
            uint64_t my_fb = 0, my_hits = 0;
            for (int py; (py = next_row.fetch_add(1)) < f.h;) {
                for (int px = 0; px < f.w; ++px) {
                    double u = (2.0 * (px + 0.5) / f.w - 1.0) * f.tan_half * double(f.w) / double(f.h);
                    double vv = (1.0 - 2.0 * (py + 0.5) / f.h) * f.tan_half;
                    double dd[3];
                    for (int i = 0; i < 3; ++i) dd[i] = f.fwd[i] + u * f.right[i] + vv * f.up[i];
                    normd(dd);
                    float d[3] = {float(dd[0]), float(dd[1]), float(dd[2])};
                    float o[3] = {float(f.eye[0]), float(f.eye[1]), float(f.eye[2])};
                    uint8_t g = mode == 0 ? trace_exact(acc, o, d) : trace(acc, smp, o, d, my_fb);
                    if (g) {
                        ++my_hits;
                        size_t i = (size_t(py) * f.w + px) * 3;
                        rgb[i] = rgb[i + 1] = rgb[i + 2] = g;
                    }
                }
            }
            fb += my_fb;
            nh += my_hits;
        };
        std::vector<std::thread> pool;
        for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
        worker();
        for (auto& th : pool) th.join();
        fallbacks = fb;
        hits = nh;
    }
};

void write_png(const std::string& path, const std::vector<uint8_t>& rgb, int w, int h) {
    std::string tmp = path + ".tmp";
    FILE* fp = std::fopen(tmp.c_str(), "wb");
    if (!fp) die("cannot write " + tmp);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) die("libpng error writing " + path);
    png_init_io(png, fp);
    png_set_IHDR(png, info, w, h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < h; ++y) png_write_row(png, const_cast<uint8_t*>(&rgb[size_t(y) * w * 3]));
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(fp);
    std::rename(tmp.c_str(), path.c_str());
}

template <typename BuildT>
int render_typed(const nanovdb::GridHandle<>& handle, const std::string& out, const std::vector<int>& views, int size,
                 int threads, int frames, int mode, const std::string& src) {
    const auto* grid = handle.grid<BuildT>();
    if (!grid) die("grid type mismatch");
    Tracer<BuildT> tr{grid, float(1.0 / grid->voxelSize()[0]), float(1.0 / grid->voxelSize()[0]), mode, mode == 2, {}};
    float l = 1.0f / std::sqrt(3.0f);
    tr.light[0] = tr.light[1] = tr.light[2] = l;
    std::ostringstream js;
    js.precision(10);
    js << "{\"source\":\"" << src << "\",\"size\":" << size << ",\"threads\":" << threads << ",\"frames\":" << frames
       << ",\"intersector\":\"" << (mode == 0 ? "exact" : mode == 1 ? "zerocrossing-refined" : "zerocrossing-raw") << "\"" << ",\"grid_bytes\":" << handle.size() << ",\"views\":[";
    for (size_t vi = 0; vi < views.size(); ++vi) {
        Frame f = paper_frame(views[vi], size);
        std::vector<uint8_t> rgb;
        std::vector<double> wall, cpu;
        uint64_t fb = 0, hits = 0;
        for (int r = 0; r < frames; ++r) {
            Clock c;
            tr.render(f, threads, rgb, fb, hits);
            wall.push_back(c.wall_ms());
            cpu.push_back(c.cpu_ms());
        }
        std::string path = out + "_" + std::to_string(views[vi]) + ".png";
        write_png(path, rgb, size, size);
        auto med = [](std::vector<double> v) { std::sort(v.begin(), v.end()); return v[v.size() / 2]; };
        js << (vi ? "," : "") << "{\"view\":" << views[vi] << ",\"output\":\"" << path << "\",\"render_ms\":" << med(wall)
           << ",\"render_cpu_ms\":" << med(cpu) << ",\"wall_ms_all\":[";
        for (size_t i = 0; i < wall.size(); ++i) js << (i ? "," : "") << wall[i];
        js << "],\"cpu_ms_all\":[";
        for (size_t i = 0; i < cpu.size(); ++i) js << (i ? "," : "") << cpu[i];
        js << "],\"hits\":" << hits << ",\"refine_fallbacks\":" << fb << "}";
    }
    js << "]}";
    std::cout << js.str() << std::endl;
    return 0;
}

int cmd_render(int argc, char** argv) {
    std::string in, out;
    std::vector<int> views = {0, 1, 2, 3};
    int size = 1024, threads = 2, frames = 1;
    int mode = 0;
    for (int i = 2; i < argc; ++i) {
        std::string a = argv[i];
        auto next = [&]() -> std::string { if (i + 1 >= argc) die("missing value after " + a); return argv[++i]; };
        if (a == "--out") out = next();
        else if (a == "--size") size = std::stoi(next());
        else if (a == "--threads") threads = std::stoi(next());
        else if (a == "--frames") frames = std::stoi(next());
        else if (a == "--raw") mode = 2;
        else if (a == "--zc") mode = 1;
        else if (a == "--views") {
            views.clear();
            std::stringstream ss(next());
            std::string s;
            while (std::getline(ss, s, ',')) views.push_back(std::stoi(s));
        } else if (in.empty()) in = a;
        else die("unexpected argument " + a);
    }
    if (in.empty() || out.empty() || size < 1 || threads < 1 || frames < 1) die("usage: vdbpeer render GRID.nvdb --out PREFIX [--views 0,1,2,3] [--size N] [--threads N] [--frames K] [--raw]");
    auto handle = nanovdb::io::readGrid(in);
    auto* meta = handle.gridMetaData();
    if (!meta) die("no grid in " + in);
    switch (meta->gridType()) {
        case nanovdb::GridType::Float: return render_typed<float>(handle, out, views, size, threads, frames, mode, in);
        case nanovdb::GridType::Fp16: return render_typed<nanovdb::Fp16>(handle, out, views, size, threads, frames, mode, in);
        case nanovdb::GridType::Fp8: return render_typed<nanovdb::Fp8>(handle, out, views, size, threads, frames, mode, in);
        case nanovdb::GridType::Fp4: return render_typed<nanovdb::Fp4>(handle, out, views, size, threads, frames, mode, in);
        case nanovdb::GridType::FpN: return render_typed<nanovdb::FpN>(handle, out, views, size, threads, frames, mode, in);
        default: die("unsupported grid type in " + in);
    }
}

}  // namespace

int main(int argc, char** argv) {
    try {
        if (argc >= 2 && std::string(argv[1]) == "build") return cmd_build(argc, argv);
        if (argc >= 2 && std::string(argv[1]) == "render") return cmd_render(argc, argv);
        die("usage: vdbpeer build|render ...");
    } catch (const std::exception& e) {
        die(e.what());
    }
}
