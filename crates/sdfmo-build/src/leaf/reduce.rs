//! Phase 6: reduction of the candidate voxels: those that cannot be hit, those hidden inside
//! another part, then merging down to the cap.

use super::samples::Samples;
use super::split::LeafComponents;
use super::{Cand, LeafCtx, Params, Scratch};
use crate::geom::trilinear;

/// Phase 6: drops from `s.cands` the voxels that cannot be hit and the hidden ones, then
/// merges down to the cap; returns whether the cap was hit (more candidates than it allows).
pub(crate) fn reduce(ctx: &LeafCtx, s: &mut Scratch) -> bool {
    let p = ctx.p;
    drop_unhit(p, &mut s.cands);
    drop_hidden(p, &mut s.cands, &s.samples, &s.components);
    let cap_hit = s.cands.len() > p.max_voxels;
    if cap_hit {
        merge_to_cap(p, &mut s.cands);
    }
    cap_hit
}

/// Drops the voxels whose quantised corners do not change sign: their zero set is empty.
pub(crate) fn drop_unhit(p: &Params, cands: &mut Vec<Cand>) {
    cands.retain(|c| p.crosses(&c.q));
}

/// Drops, in order, each voxel all of whose component's samples lie deeper than
/// [`LeafParams::bury`] inside a volume voxel of another component (it can never be seen). A voxel
/// whose component has no sample stays.
pub(crate) fn drop_hidden(
    p: &Params,
    cands: &mut Vec<Cand>,
    samples: &Samples,
    comps: &LeafComponents,
) {
    let bury = p.bury * p.h;
    let mut i = 0;
    while i < cands.len() {
        let me = cands[i];
        let mut any = false;
        let mut hidden = true;
        for (l, li) in samples.iter() {
            if comps.of[li as usize] != me.comp {
                continue;
            }
            any = true;
            let inside = cands.iter().enumerate().any(|(j, o)| {
                j != i && !o.surface && o.comp != me.comp && trilinear(&o.q, l) < -bury
            });
            if !inside {
                hidden = false;
                break;
            }
        }
        if any && hidden {
            cands.remove(i);
        } else {
            i += 1;
        }
    }
}

/// Reduces `cands` to `p.max_voxels`: merge the most similar volume voxels (min = union), then
/// the most nearly coplanar surface voxels (average of the two, oriented alike), then drop the
/// last ones.
pub(crate) fn merge_to_cap(p: &Params, cands: &mut Vec<Cand>) {
    let diff = |a: &[f32; 8], b: &[f32; 8], s: f32| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - s * y).abs())
            .fold(0.0f32, f32::max)
    };
    while cands.len() > p.max_voxels {
        // Most similar pair of the same kind, volume pairs first.
        let mut best: Option<(usize, usize, f32, f32)> = None;
        for surface in [false, true] {
            for i in 0..cands.len() {
                if cands[i].surface != surface {
                    continue;
                }
                for j in i + 1..cands.len() {
                    if cands[j].surface != surface {
                        continue;
                    }
                    let (d, sg) = if surface {
                        let dp = diff(&cands[i].c, &cands[j].c, 1.0);
                        let dn = diff(&cands[i].c, &cands[j].c, -1.0);
                        if dn < dp {
                            (dn, -1.0)
                        } else {
                            (dp, 1.0)
                        }
                    } else {
                        (diff(&cands[i].c, &cands[j].c, 1.0), 1.0)
                    };
                    if best.is_none_or(|b| d < b.2) {
                        best = Some((i, j, d, sg));
                    }
                }
            }
            if best.is_some() {
                break;
            }
        }
        let Some((i, j, _, sg)) = best else {
            cands.truncate(p.max_voxels);
            break;
        };
        let b = cands.remove(j);
        let a = &mut cands[i];
        for k in 0..8 {
            a.c[k] = if a.surface {
                0.5 * (a.c[k] + sg * b.c[k])
            } else {
                a.c[k].min(b.c[k])
            };
        }
        a.q = p.q8(&a.c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::corner_offset;
    use glam::Vec3;
    use sdfmo_format::ValueBits;

    fn cand(c: [f32; 8], surface: bool, comp: u32) -> Cand {
        Cand {
            c,
            q: c,
            surface,
            comp,
        }
    }

    /// The plane `x = x0` of a unit cell (local units).
    fn plane_x(x0: f32) -> [f32; 8] {
        std::array::from_fn(|i| corner_offset(i).x - x0)
    }

    #[test]
    fn reduce_merges_volume_then_surface() {
        let p = Params::new(4, ValueBits::Eight, 2);
        let mut c = vec![
            cand([0.1; 8], false, 0),
            cand([0.2; 8], false, 0),
            cand([0.5; 8], true, 0),
            cand([-0.5; 8], true, 0),
        ];
        merge_to_cap(&p, &mut c);
        assert_eq!(c.len(), 2);
        assert!(!c[0].surface && c[0].c[0] == 0.1);
        // The two surface voxels are F and −F: they merge with orientation into one.
        assert!(c[1].surface && (c[1].c[0].abs() - 0.5).abs() < 1e-6);
    }

    #[test]
    fn voxels_without_a_zero_set_go() {
        let p = Params::new(0, ValueBits::Eight, 8);
        let mut c = vec![cand([0.5; 8], false, 0), cand(plane_x(0.5), false, 1)];
        drop_unhit(&p, &mut c);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].comp, 1);
    }

    #[test]
    fn a_voxel_buried_in_another_part_goes() {
        // Depth 1: cell edge 1, so local and world lengths agree.
        let p = Params::new(1, ValueBits::Eight, 8);
        let samples = Samples {
            points: vec![Vec3::new(0.3, 0.5, 0.5), Vec3::new(0.8, 0.5, 0.5)],
            triangle: vec![0, 1],
        };
        let comps = LeafComponents {
            of: vec![0, 1],
            ..Default::default()
        };
        // Component 0 (its sample at x = 0.3) is 0.6 inside component 1's voxel (x < 0.9).
        let mut c = vec![cand(plane_x(0.3), false, 0), cand(plane_x(0.9), false, 1)];
        drop_hidden(&p, &mut c, &samples, &comps);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].comp, 1);
        // A surface voxel hides nothing.
        let mut c = vec![cand(plane_x(0.3), false, 0), cand(plane_x(0.9), true, 1)];
        drop_hidden(&p, &mut c, &samples, &comps);
        assert_eq!(c.len(), 2);
        // Within `bury` of the other's zero set: still visible.
        let mut c = vec![cand(plane_x(0.3), false, 0), cand(plane_x(0.32), false, 1)];
        drop_hidden(&p, &mut c, &samples, &comps);
        assert_eq!(c.len(), 2);
    }
}
