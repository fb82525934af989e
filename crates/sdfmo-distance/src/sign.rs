//! Signed distance: the sign of a closest point (pseudo-normals, the winding number, the
//! hybrid shortcuts), batches, and the winding number itself.

use super::*;

impl MeshDistance {
    /// Signed distance from `p` to the mesh, negative inside, with the sign of
    /// [`sign_mode`](Self::sign_mode).
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        let c = self.closest_point(p);
        self.apply_sign(p, &c)
    }

    /// Whether triangle `t`'s face normal points out of the solid the winding number sees: it
    /// lies in a clean part of the surface (the one-time per-triangle data of the winding
    /// mode's face-normal shortcut, see [`prepare_sign`](Self::prepare_sign), gives it a
    /// radius), so a point whose closest point lies in its face interior can take its sign from
    /// the face normal. `false` for an index out of range, and in pseudo-normal mode, which
    /// keeps no winding data (there every face normal signs).
    pub fn face_normal_agrees_with_winding(&self, t: u32) -> bool {
        if self.sign != SignMode::Winding {
            return false;
        }
        self.clean_radius(t).is_some_and(|r| r > 0.0)
    }

    /// The winding number's verdict on `p` where it is decisive: `Some(inside)` when the coarse
    /// winding number lies farther than [`COARSE_WINDING_MARGIN`] from ½ (within a closed
    /// part, or outside every part), `None` near ½ (beside an open sheet, where only the
    /// surface's own orientation tells its sides apart).
    pub fn decisive_winding_inside(&self, p: Vec3) -> Option<bool> {
        let w = self.winding_number_scaled(p, COARSE_FAR_SCALE);
        ((w - 0.5).abs() > COARSE_WINDING_MARGIN).then_some(w > 0.5)
    }

    /// Signs the distance of a closest point `c` of `p` (found by any of the closest-point
    /// queries on this mesh) with the mode of this `MeshDistance`. Lets a caller that already has
    /// the closest point (from a bounded or hinted query) avoid a second search.
    pub fn sign_closest(&self, p: Vec3, c: &ClosestPoint) -> f32 {
        self.apply_sign(p, c)
    }

    #[inline]
    pub(crate) fn apply_sign(&self, p: Vec3, c: &ClosestPoint) -> f32 {
        match self.sign {
            SignMode::Winding => {
                if self.winding_inside_near(p, c) {
                    -c.distance
                } else {
                    c.distance
                }
            }
            _ => self.pseudo_normal_sign(p, c),
        }
    }

    /// Whether the winding number of `p` exceeds ½ for a query whose closest point is `c`:
    /// from the face normal when `c` lies in the interior of a clean triangle (see
    /// [`clean`](mod@crate::clean)) and `p` is closer to it than
    /// [`CLEAN_DISTANCE_FRACTION`] of the clean radius, else [`winding_inside`](Self::winding_inside).
    #[inline]
    pub(crate) fn winding_inside_near(&self, p: Vec3, c: &ClosestPoint) -> bool {
        if c.feature == Feature::Face && self.within_clean_radius(c.triangle, c.distance) {
            let n = self.normals.face[c.triangle as usize];
            return (p - c.point).dot(n) < 0.0;
        }
        self.winding_inside(p)
    }

    /// Whether `winding_number(p) > ½`, decided in two stages: a coarse pass with
    /// β = [`COARSE_WINDING_BETA`] (far fewer exact solid angles near the surface) settles every
    /// point whose coarse w lies farther than [`COARSE_WINDING_MARGIN`] from ½ (away from the
    /// rims and seams of an open or non-manifold mesh w is close to 0 or 1); only the others are
    /// recomputed with the full [`WINDING_BETA`].
    #[inline]
    pub fn winding_inside(&self, p: Vec3) -> bool {
        self.decisive_winding_inside(p)
            .unwrap_or_else(|| self.winding_number(p) > 0.5)
    }

    #[inline]
    pub(crate) fn pseudo_normal_sign(&self, p: Vec3, c: &ClosestPoint) -> f32 {
        let Some(&idx) = self.mesh.triangles().get(c.triangle as usize) else {
            return c.distance;
        };
        sign_by_pseudo_normal(
            p,
            c,
            self.normals.normal(c.triangle as usize, idx, c.feature),
        )
    }

    /// Signed distances of many points, in parallel (rayon), in the same order; each value is
    /// bit-identical to [`signed_distance`](Self::signed_distance) of that point (see
    /// [`map_points`](Self::map_points) for the order they are visited in). The winding
    /// sign's one-time data is made for the BVH leaves the points reach, as they reach them
    /// ([`prepare_sign`](Self::prepare_sign) makes all of it): on abc1, 50,000 points on one
    /// thread took 0.60–0.63 s in a first call that made every leaf's and 0.19–0.20 s making
    /// only theirs (0.14 s once made; quiet machine, three runs).
    pub fn signed_distances(&self, points: &[Vec3]) -> Vec<f32> {
        self.map_points(points, |md, p| md.signed_distance(p))
    }

    /// Runs `query` on every point, in parallel (rayon), and returns the answers in the
    /// caller's order. From 256 points on, the points are visited in Morton (Z-curve) order so
    /// that consecutive queries of a thread touch the same BVH and winding-tree nodes: up to 2×
    /// faster per point than the caller's order on shuffled points (bunny, 200 k points,
    /// docs/results/python.md). For closest points, faces or any per-point query built on this
    /// type; `query` sees each point once.
    pub fn map_points<T, F>(&self, points: &[Vec3], query: F) -> Vec<T>
    where
        T: Send,
        F: Fn(&MeshDistance, Vec3) -> T + Sync,
    {
        if points.len() < 256 {
            return points.iter().map(|&p| query(self, p)).collect();
        }
        let order = morton_order(points);
        let sorted: Vec<T> = order
            .par_iter()
            .with_min_len(64)
            .map(|&i| query(self, points[i]))
            .collect();
        let mut slots: Vec<Option<T>> =
            std::iter::repeat_with(|| None).take(points.len()).collect();
        for (&i, v) in order.iter().zip(sorted) {
            slots[i] = Some(v);
        }
        slots
            .into_iter()
            .map(|v| v.expect("morton_order is a permutation"))
            .collect()
    }

    /// Generalised winding number of the mesh at `p` (Jacobson et al. 2013), with the
    /// hierarchical approximation of Barill et al. 2018 (accuracy parameter
    /// [`WINDING_BETA`]): ≈ 1 inside a closed outward-oriented surface, ≈ 0 outside.
    pub fn winding_number(&self, p: Vec3) -> f32 {
        self.winding_number_scaled(p, 1.0)
    }

    /// Hierarchical winding number at `p` with accuracy parameter `beta` instead of
    /// [`WINDING_BETA`]: a node (or a triangle of a near leaf) is taken as its expansion when `p`
    /// is farther than `beta` times its radius from its centre. Smaller is faster and coarser;
    /// `beta` is clamped to at least 1 (the expansion diverges inside the bounding sphere), and a
    /// NaN `beta` means [`WINDING_BETA`].
    pub fn winding_number_with_beta(&self, p: Vec3, beta: f32) -> f32 {
        let beta = if beta.is_nan() {
            WINDING_BETA
        } else {
            beta.max(1.0)
        };
        let k = beta / WINDING_BETA;
        self.winding_number_scaled(p, k * k)
    }

    /// The hierarchical winding number with every far-field threshold (β·r)² multiplied by
    /// `scale`.
    #[inline]
    pub(crate) fn winding_number_scaled(&self, p: Vec3, scale: f32) -> f32 {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (detected just above).
            return unsafe { self.winding_number_scaled_avx(p, scale) };
        }
        self.winding_number_scaled_any(p, scale)
    }

    /// [`winding_number_scaled`](Self::winding_number_scaled) compiled with AVX enabled, as
    /// `closest_bounded_avx` and for the same reason: abc1's signed query 20,053 → 19,377
    /// instructions per point, the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn winding_number_scaled_avx(&self, p: Vec3, scale: f32) -> f32 {
        self.winding_number_scaled_any(p, scale)
    }

    /// [`winding_number_scaled`](Self::winding_number_scaled) for any CPU.
    #[inline(always)]
    pub(crate) fn winding_number_scaled_any(&self, p: Vec3, scale: f32) -> f32 {
        // Depth first, the second child of an opened node taken at once and the first one
        // kept for after its subtree: the order the sum has always been taken in (pushing both
        // and popping the second straight away), without that push and pop. At most one entry
        // per level. Bunny, 50,000 points: first call 839.0 -> 815.4 M instructions (its
        // coarse probes 159.0 -> 142.0 M), second call 522.8 -> 516.2 M.
        let mut stack = [0u32; MAX_BVH_DEPTH + 1];
        let mut sp = 0usize;
        let mut node = 0u32;
        let mut sum = 0.0f32;
        loop {
            let w = &self.winding[node as usize];
            let d = w.center - p;
            let d2 = d.length_squared();
            if d2 > w.far2 * scale {
                sum += w.far_field(d, d2);
            } else if w.count > 0 {
                // Each triangle as a dipole when far enough, else exactly; four at a time
                // (`WindingPacket`), summed one by one in the leaf's order.
                let count = w.count as usize;
                let first = w.first as usize;
                let packets = &self.winding_packets[first..first + count.div_ceil(4)];
                let mut summed = false;
                #[cfg(target_arch = "x86_64")]
                if let [lo, hi] = packets {
                    if std::is_x86_feature_detected!("avx") {
                        // SAFETY: the CPU has AVX (detected just above).
                        let lanes = unsafe { winding::avx::solid_angles(lo, hi, p, scale) };
                        for &v in &lanes[..count] {
                            sum += v;
                        }
                        summed = true;
                    }
                }
                if !summed {
                    let mut left = count;
                    for packet in packets {
                        let lanes = packet.solid_angles(p, scale).to_array();
                        for &v in &lanes[..left.min(4)] {
                            sum += v;
                        }
                        left = left.saturating_sub(4);
                    }
                }
            } else {
                stack[sp] = w.first;
                sp += 1;
                node = w.first + 1;
                continue;
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        sum / (4.0 * std::f32::consts::PI)
    }

    /// Exact generalised winding number at `p`: the sum over every triangle, O(n). For tests and
    /// for measuring the accuracy of [`winding_number`](Self::winding_number).
    pub fn winding_number_exact(&self, p: Vec3) -> f64 {
        let s: f64 = self
            .tris
            .iter()
            .map(|t| solid_angle(p, t[0], t[1], t[2]) as f64)
            .sum();
        s / (4.0 * std::f64::consts::PI)
    }
}
