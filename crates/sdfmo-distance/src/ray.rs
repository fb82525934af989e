//! Ray queries on the mesh: closest watertight hit and occlusion, through the BVH.

use super::*;

impl MeshDistance {
    /// Closest hit of the ray `origin + t·dir`, t in `[t_min, t_max]`, with the watertight
    /// ray–triangle test. `dir` need not be unit length (t is in units of `dir`). `None` for a
    /// zero or non-finite direction.
    pub fn ray_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<RayHit> {
        let (t, slot) = self.trace(origin, dir, t_min, t_max, false)?;
        let tri = self.leaf_ids[slot];
        let [a, b, c] = self.leaf_tris[slot];
        let n = (b - a).cross(c - a).normalize_or_zero();
        let normal = if n == Vec3::ZERO {
            -dir.normalize_or_zero()
        } else {
            n
        };
        Some(RayHit {
            t,
            triangle: tri,
            normal,
        })
    }

    /// Whether the ray `origin + t·dir` hits anything with t in `[t_min, t_max]` (any hit, not
    /// the closest: faster than [`ray_hit`](Self::ray_hit)).
    pub fn ray_occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        self.trace(origin, dir, t_min, t_max, true).is_some()
    }

    /// Ordered BVH traversal; returns (t, leaf slot).
    pub(crate) fn trace(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
        any: bool,
    ) -> Option<(f32, usize)> {
        let ray = WatertightRay::new(origin, dir)?;
        if t_min.is_nan() || t_max.is_nan() || t_min > t_max {
            return None;
        }
        // Zero direction components replaced by a tiny value: no 0·∞ NaN in the slab test.
        let safe = |d: f32| {
            if d.abs() < 1e-30 {
                1e-30f32.copysign(d)
            } else {
                d
            }
        };
        let inv = Vec3A::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
        let o = Vec3A::from(origin);
        let nodes = &self.nodes[..];
        // Conservative slab test (Ize 2013): widen the interval by a few ulps so rounding can
        // never cull a box whose triangle the watertight test would hit.
        let slab = |n: &Bvh2Node, t_far: f32| -> f32 {
            let b = n.aabb();
            let t0 = (b.min - o) * inv;
            let t1 = (b.max - o) * inv;
            let tn = t0.min(t1).max_element();
            let tf = t0.max(t1).min_element();
            let tn = tn - tn.abs() * 1e-6;
            let tf = tf + tf.abs() * 1e-6;
            let lo = tn.max(t_min);
            let hi = tf.min(t_far);
            if lo <= hi {
                lo
            } else {
                f32::INFINITY
            }
        };
        let mut best_t = t_max;
        let mut best_slot = usize::MAX;
        let mut stack = [(0u32, 0.0f32); MAX_BVH_DEPTH];
        let mut sp = 0usize;
        if slab(&nodes[0], best_t).is_finite() {
            let mut ni = 0usize;
            loop {
                let node = &nodes[ni];
                if node.prim_count > 0 {
                    let start = node.first_index as usize;
                    for slot in start..start + node.prim_count as usize {
                        let [a, b, c] = self.leaf_tris[slot];
                        if let Some(t) = ray.intersect(a, b, c, t_min, best_t) {
                            best_t = t;
                            best_slot = slot;
                            if any {
                                return Some((t, slot));
                            }
                        }
                    }
                } else {
                    let l = node.first_index as usize;
                    let tl = slab(&nodes[l], best_t);
                    let tr = slab(&nodes[l + 1], best_t);
                    let (near, tn, far, tf) = if tl <= tr {
                        (l, tl, l + 1, tr)
                    } else {
                        (l + 1, tr, l, tl)
                    };
                    if tn.is_finite() {
                        if tf.is_finite() {
                            stack[sp] = (far as u32, tf);
                            sp += 1;
                        }
                        ni = near;
                        continue;
                    }
                }
                let mut next = None;
                while sp > 0 {
                    sp -= 1;
                    let (n, t) = stack[sp];
                    if t <= best_t {
                        next = Some(n as usize);
                        break;
                    }
                }
                match next {
                    Some(n) => ni = n,
                    None => break,
                }
            }
        }
        (best_slot != usize::MAX).then_some((best_t, best_slot))
    }
}
