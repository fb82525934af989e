// render.wgsl: one primary ray per pixel through `sdfmo.wgsl` (concatenated before this file),
// shaded as sdfmo-render does: mask, depth, normal or lambert (no shadows, no occlusion).
//
// BINDING LAYOUT (group 0):
//   binding 0  storage, read        smo: array<u32>          the `.smo` file (see sdfmo.wgsl):
//                                                            a 1.x or 3.0 file, traced as it is, or
//                                                            with params.pixel_error > 0 a
//                                                            2.0 file (levels of detail), each
//                                                            ray at the level its error needs
//   binding 1  uniform              params: SmoRenderParams  camera, mode, shading (generated
//                                                            before this file from the host's
//                                                            struct: renderer.rs, `Params`)
//   binding 2  storage, read_write  pixels: array<SmoPixel>  per pixel: normal, t
//   binding 3  storage, read_write  colors: array<u32>       per pixel: 0x00BBGGRR, 8 bits each
//   binding 4  storage, read        rays: array<vec4<f32>>   the camera's ray terms (below)
//   binding 5  storage, read        tiles: array<u32>        the 8 × 8 pixel tiles the dispatch
//                                                            draws, tile (x, y) as x | y << 16
//
// Ray directions are rounded to f32 from the exact (f64) value, as the CPU renderer rounds its
// own: the host passes, as double-float pairs (hi = f32(x), lo = f32(x − hi)), the column term
// fwd + u·right of every pixel column (entries 2·px, 2·px + 1: hi.xyz, lo.xyz) and then the row
// term v·up of every row (entries 2·width + 2·py, + 1). The kernel adds them and normalises in
// double-float arithmetic (error-free transformations with fma) before rounding once, so a
// direction matches the CPU's bit for bit except within ~2^-20 ulp of a rounding tie.
// Pixels are row-major from the top-left, `y · width + x`.
//
// TILES. Each workgroup of 8 × 8 draws the tile `tiles[wg.y · groups.x + wg.x]` (none past the
// list's end). The host splits the image's tiles into two lists (renderer.rs): those whose
// rays may meet the octree's occupied box, drawn by `smo_render`, and the others, background
// by construction, filled by `smo_background`, which holds no traversal code. Why: lavapipe
// runs every instruction of a shader for a SIMD group even when no lane takes the branch, so
// a traced tile costs the whole kernel's code once even if all its rays miss (an empty 1024²
// frame took 440 ms of a ~520 ms frame before this split); on a GPU the culled tiles also
// cost nothing but their writes.

/// One pixel's hit: the viewer-facing unit normal (0 for the background and in the mask and
/// depth modes) and the ray parameter (SMO_FAR for the background).
struct SmoPixel {
    normal: vec3<f32>,
    t: f32,
}

@group(0) @binding(1) var<uniform> params: SmoRenderParams;
@group(0) @binding(2) var<storage, read_write> pixels: array<SmoPixel>;
@group(0) @binding(3) var<storage, read_write> colors: array<u32>;
@group(0) @binding(4) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> tiles: array<u32>;

/// a + b exactly, as (sum, error) (Knuth's TwoSum).
fn smo_two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    let bb = s - a;
    return vec2<f32>(s, (a - (s - bb)) + (b - bb));
}

/// a · b exactly, as (product, error).
fn smo_two_prod(a: f32, b: f32) -> vec2<f32> {
    let p = a * b;
    return vec2<f32>(p, fma(a, b, -p));
}

/// Double-float addition (hi, lo) + (hi, lo).
fn smo_df_add(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let s = smo_two_sum(a.x, b.x);
    let e = s.y + a.y + b.y;
    return smo_two_sum(s.x, e);
}

/// Double-float square of (hi, lo).
fn smo_df_sqr(a: vec2<f32>) -> vec2<f32> {
    let p = smo_two_prod(a.x, a.x);
    return smo_two_sum(p.x, p.y + 2.0 * a.x * a.y);
}

/// The unit direction of pixel (px, py): normalize(column + row) in double-float, rounded once.
fn smo_primary_dir(px: u32, py: u32) -> vec3<f32> {
    let ch = rays[2u * px].xyz;
    let cl = rays[2u * px + 1u].xyz;
    let row = 2u * params.width + 2u * py;
    let rh = rays[row].xyz;
    let rl = rays[row + 1u].xyz;
    var sh: vec3<f32>;
    var sl: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        let s = smo_df_add(vec2<f32>(ch[k], cl[k]), vec2<f32>(rh[k], rl[k]));
        sh[k] = s.x;
        sl[k] = s.y;
    }
    let d2 = smo_df_add(smo_df_add(smo_df_sqr(vec2<f32>(sh.x, sl.x)), smo_df_sqr(vec2<f32>(sh.y, sl.y))), smo_df_sqr(vec2<f32>(sh.z, sl.z)));
    // len = y + (d2 − y²) / 2y, one Newton step from the f32 square root.
    let y = sqrt(d2.x);
    let yy = smo_two_prod(y, y);
    let corr = (((d2.x - yy.x) - yy.y) + d2.y) / (2.0 * y);
    var out: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        // q = s / len, then one correction with the exact remainder s − q·len.
        let q = sh[k] / y;
        let p = smo_two_prod(q, y);
        let rem = (((sh[k] - p.x) - p.y) + sl[k]) - q * corr;
        out[k] = q + rem / y;
    }
    return out;
}

/// A value in [0, 1] (clamped) to 8 bits, rounding half away from zero as the CPU does
/// (WGSL's round() rounds half to even).
fn smo_to_u8(value: f32) -> u32 {
    return u32(floor(clamp(value, 0.0, 1.0) * 255.0 + 0.5));
}

/// The built-in inputs of both entry points: the workgroup (which listed tile), the dispatch's
/// workgroup count, and the invocation's place in its tile.
struct SmoTileInvocation {
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
}

/// The pixel an invocation draws: its coordinates and its index in `pixels` and `colors`;
/// `drawn` is false past the tile list or the image (the invocation draws nothing).
struct SmoTilePixel {
    x: u32,
    y: u32,
    index: u32,
    drawn: bool,
}

/// The pixel `inv` draws.
fn smo_tile_pixel(inv: SmoTileInvocation) -> SmoTilePixel {
    let k = inv.wg.y * inv.groups.x + inv.wg.x;
    if k >= arrayLength(&tiles) {
        return SmoTilePixel(0u, 0u, 0u, false);
    }
    let x = (tiles[k] & 0xffffu) * 8u + inv.local.x;
    let y = (tiles[k] >> 16u) * 8u + inv.local.y;
    if x >= params.width || y >= params.height {
        return SmoTilePixel(0u, 0u, 0u, false);
    }
    return SmoTilePixel(x, y, y * params.width + x, true);
}

/// Writes the background at pixel `index`: no normal, t = SMO_FAR, black.
fn smo_write_background(index: u32) {
    pixels[index] = SmoPixel(vec3<f32>(0.0), SMO_FAR);
    colors[index] = 0u;
}

/// Background for every pixel of the listed tiles (tiles no primary ray of which meets the
/// occupied box).
@compute @workgroup_size(8, 8, 1)
fn smo_background(inv: SmoTileInvocation) {
    let at = smo_tile_pixel(inv);
    if !at.drawn {
        return;
    }
    smo_write_background(at.index);
}

/// One primary ray per pixel of the listed tiles, traced and shaded.
@compute @workgroup_size(8, 8, 1)
fn smo_render(inv: SmoTileInvocation) {
    let at = smo_tile_pixel(inv);
    if !at.drawn {
        return;
    }
    let index = at.index;
    let dir = smo_primary_dir(at.x, at.y);
    let ray = SmoRay(params.eye, dir);

    // One call of smo_intersect for both kinds of file: lavapipe runs (and zeroes the
    // variables of) every inlined copy for each SIMD group (an empty 1024² frame, abc5, with
    // the old 50-cell stack: 1.1–1.5 s with two copies, 0.44–0.49 s with one, 17 ms with none).
    var info: SmoInfo;
    var hit: SmoHit;
    hit.hit = false;
    let lod = smo_lod(params.dequant);
    var trace: SmoLodTrace;
    if params.pixel_error > 0.0 {
        // A file with levels (2.0): each ray at the level its screen-space error needs.
        trace = smo_lod_trace_start(lod, ray, 0.0, SMO_FAR, params.pixel_error, params.pixel_angle);
    } else {
        let root = smo_root_span(ray, 0.0, SMO_FAR);
        trace.tracing = root.x <= root.y;
    }
    loop {
        if !trace.tracing {
            break;
        }
        if params.pixel_error > 0.0 {
            info = smo_lod_level_info(lod, trace.level);
        } else {
            info = smo_info(params.dequant);
        }
        hit = smo_intersect(info, ray, 0.0, SMO_FAR);
        if params.pixel_error <= 0.0 || !smo_lod_trace_next(lod, &trace, hit, params.pixel_error, params.pixel_angle) {
            break;
        }
    }
    if !hit.hit {
        smo_write_background(index);
        return;
    }
    var n = vec3<f32>(0.0);
    if params.mode >= 2u {
        n = smo_hit_normal(info, ray, hit);
        if dot(n, dir) > 0.0 {
            n = -n;
        }
    }
    var rgb = vec3<u32>(255u);
    switch params.mode {
        case 1u: {
            let span = params.depth_far - params.depth_near;
            var g = 1.0;
            if span > 0.0 {
                g = (params.depth_far - hit.t) / span;
            }
            rgb = vec3<u32>(max(smo_to_u8(g), 1u));
        }
        case 2u: {
            let c = n * 0.5 + vec3<f32>(0.5);
            rgb = vec3<u32>(smo_to_u8(c.x), smo_to_u8(c.y), smo_to_u8(c.z));
        }
        case 3u: {
            let direct = params.light_intensity * max(dot(n, params.light), 0.0);
            rgb = vec3<u32>(smo_to_u8(params.ambient + direct));
        }
        default: {}
    }
    pixels[index] = SmoPixel(n, hit.t);
    colors[index] = rgb.x | (rgb.y << 8u) | (rgb.z << 16u);
}
