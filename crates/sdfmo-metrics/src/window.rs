//! Where two error maps differ most: the square window with the largest summed difference, found
//! with a summed-area table, and the mean of a map over a window. The sweep's page cuts its
//! zoomed crops there; the search belongs with the maps it reads.

use crate::FlipResult;

/// A square window of an image: its top-left pixel and its edge in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    /// Left column.
    pub x: u32,
    /// Top row (from the top of the image).
    pub y: u32,
    /// Edge length in pixels.
    pub size: u32,
}

/// The square window of edge `size` (clamped to the map) with the largest sum of `map`
/// (row-major, `width` × `height`): the first such window in row-major order on ties. A map of
/// the wrong length or an empty one gives the window at (0, 0).
///
/// One pass builds the summed-area table (in `f64`, so the sums of a 8192² map of values in
/// 0..=1 stay exact to far below one pixel's value), a second reads every window in O(1).
pub fn hottest_window(map: &[f32], width: u32, height: u32, size: u32) -> Window {
    let (w, h) = (width as usize, height as usize);
    let edge = (size as usize).min(w).min(h);
    let at_origin = Window {
        x: 0,
        y: 0,
        size: edge as u32,
    };
    if edge == 0 || map.len() != w * h {
        return at_origin;
    }
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += f64::from(map[y * w + x]);
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let at = |x: usize, y: usize| sat[y * (w + 1) + x];
    let mut best = (f64::NEG_INFINITY, 0, 0);
    for y in 0..=h - edge {
        for x in 0..=w - edge {
            let sum = at(x + edge, y + edge) - at(x, y + edge) - at(x + edge, y) + at(x, y);
            if sum > best.0 {
                best = (sum, x, y);
            }
        }
    }
    Window {
        x: best.1 as u32,
        y: best.2 as u32,
        size: edge as u32,
    }
}

/// The window of edge `size` where two FLIP maps of the same images' size differ most (the sum
/// of |a − b| is largest): where one method's error is far from the other's.
pub fn most_different_window(a: &FlipResult, b: &FlipResult, size: u32) -> Window {
    let diff: Vec<f32> = a
        .map
        .iter()
        .zip(&b.map)
        .map(|(x, y)| (x - y).abs())
        .collect();
    let (width, height) = if a.map.len() == b.map.len() {
        (a.width, a.height)
    } else {
        (0, 0)
    };
    hottest_window(&diff, width, height, size)
}

impl FlipResult {
    /// Mean error over the pixels of `window` that lie inside the map (0 for none).
    pub fn window_mean(&self, window: Window) -> f64 {
        let (mut sum, mut count) = (0.0f64, 0u64);
        for y in window.y..window.y.saturating_add(window.size).min(self.height) {
            for x in window.x..window.x.saturating_add(window.size).min(self.width) {
                if let Some(v) = self.get(x, y) {
                    sum += f64::from(v);
                    count += 1;
                }
            }
        }
        if count == 0 {
            0.0
        } else {
            sum / count as f64
        }
    }
}

/// Median of `values` (the mean of the middle two for an even count), `None` when empty. NaN
/// sorts last (`total_cmp`), so it counts as the largest value rather than poisoning the sort.
pub fn median(mut values: Vec<f64>) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hottest_window_finds_the_hot_spot() {
        let (w, h) = (40u32, 30u32);
        let mut map = vec![0.1f32; (w * h) as usize];
        for y in 20..24 {
            for x in 5..9 {
                map[(y * w + x) as usize] = 1.0;
            }
        }
        let at = |x, y, size| Window { x, y, size };
        assert_eq!(hottest_window(&map, w, h, 4), at(5, 20, 4));
        // A larger window still covers the spot, the first such position in row-major order.
        assert_eq!(hottest_window(&map, w, h, 8), at(1, 16, 8));
        // Clamped to the map; a map of the wrong length gives the origin.
        assert_eq!(hottest_window(&map, w, h, 100), at(0, 0, 30));
        assert_eq!(hottest_window(&map[1..], w, h, 4), at(0, 0, 4));
    }

    #[test]
    fn most_different_window_and_its_means() {
        let flat = |v: f32| FlipResult {
            mean: v,
            width: 20,
            height: 10,
            map: vec![v; 200],
        };
        let a = flat(0.2);
        let mut b = flat(0.2);
        b.map[3 * 20 + 15] = 1.0;
        let win = most_different_window(&a, &b, 3);
        assert!(
            win.x <= 15 && 15 < win.x + 3 && win.y <= 3 && 3 < win.y + 3,
            "{win:?}"
        );
        assert!((a.window_mean(win) - 0.2).abs() < 1e-6);
        assert!((b.window_mean(win) - (0.2 * 8.0 + 1.0) / 9.0).abs() < 1e-6);
        // Partly outside: only the pixels inside count.
        let edge = Window {
            x: 19,
            y: 9,
            size: 4,
        };
        assert!((b.window_mean(edge) - 0.2).abs() < 1e-6);
    }

    #[test]
    fn median_of_even_and_odd() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0]), Some(2.5));
        assert_eq!(median(vec![]), None);
    }
}
