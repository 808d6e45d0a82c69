//! Ways for a palm around things it cannot pass over: the shortest path in the horizontal plane
//! from one point to another that keeps a clearance from every obstacle's footprint.
//!
//! Each obstacle is a rectangle (a measured footprint: centre, major axis, half extents); grown by
//! the clearance it becomes a larger rectangle (which holds the exact rounded one). The shortest
//! way among such rectangles runs straight or through their corners: the visibility graph over the
//! two end points and the corners, searched with Dijkstra's algorithm (a few obstacles: a few
//! dozen nodes). A segment may run along a grown rectangle's side or touch its corner, not cross
//! its inside. An end point inside a grown rectangle (a palm that stopped against a post) may
//! leave it (or enter it) by its own segment, which comes no nearer the obstacle than the point.

/// A thing the palm keeps clear of: its footprint on the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Centre (x, y; m).
    pub center: [f64; 2],
    /// Unit direction (x, y) of its major axis.
    pub major_axis: [f64; 2],
    /// Half extents along the major and the minor axis (m).
    pub half: [f64; 2],
    /// Height (m, world) of its top: a whole-arm sweep ([`crate::sweep`]) may pass over it.
    /// `f64::INFINITY` when unknown.
    pub top: f64,
}

impl Obstacle {
    /// The least rectangle along the longer one's major axis that holds both footprints, with the
    /// higher top.
    pub fn union(&self, other: &Obstacle) -> Obstacle {
        let (a, b) = if self.half[0] >= other.half[0] {
            (self, other)
        } else {
            (other, self)
        };
        let u = a.major_axis;
        let v = [-u[1], u[0]];
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for o in [a, b] {
            let ou = o.major_axis;
            let ov = [-ou[1], ou[0]];
            for (su, sv) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                let c = [
                    o.center[0] + su * o.half[0] * ou[0] + sv * o.half[1] * ov[0],
                    o.center[1] + su * o.half[0] * ou[1] + sv * o.half[1] * ov[1],
                ];
                for (k, d) in [u, v].iter().enumerate() {
                    let t = c[0] * d[0] + c[1] * d[1];
                    lo[k] = lo[k].min(t);
                    hi[k] = hi[k].max(t);
                }
            }
        }
        let (mu, mv) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
        Obstacle {
            center: [mu * u[0] + mv * v[0], mu * u[1] + mv * v[1]],
            major_axis: u,
            half: [0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])],
            top: a.top.max(b.top),
        }
    }

    /// `p` in the obstacle's frame (along the major axis, across it).
    fn local(&self, p: [f64; 2]) -> [f64; 2] {
        let (dx, dy) = (p[0] - self.center[0], p[1] - self.center[1]);
        let [ax, ay] = self.major_axis;
        [dx * ax + dy * ay, -dx * ay + dy * ax]
    }

    /// The corners of the rectangle grown by `grow` (counter-clockwise).
    fn corners(&self, grow: f64) -> [[f64; 2]; 4] {
        let [ax, ay] = self.major_axis;
        let (a, b) = (self.half[0] + grow, self.half[1] + grow);
        [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)].map(|(s, t)| {
            [
                self.center[0] + s * a * ax - t * b * ay,
                self.center[1] + s * a * ay + t * b * ax,
            ]
        })
    }

    /// How far `p` lies outside the rectangle, as its grown rectangles measure it (the least
    /// growth that reaches it, less a millimetre); negative inside.
    fn room(&self, p: [f64; 2]) -> f64 {
        let l = self.local(p);
        (l[0].abs() - self.half[0]).max(l[1].abs() - self.half[1]) - 1e-3
    }

    /// Whether `p` lies strictly inside the rectangle grown by `grow`.
    fn contains(&self, p: [f64; 2], grow: f64) -> bool {
        let l = self.local(p);
        l[0].abs() < self.half[0] + grow - EPS && l[1].abs() < self.half[1] + grow - EPS
    }

    /// Whether the segment `p`–`q` crosses the inside of the rectangle grown by `grow` (slab
    /// clipping in the obstacle's frame; touching a side or a corner is not crossing).
    fn crossed_by(&self, p: [f64; 2], q: [f64; 2], grow: f64) -> bool {
        let (a, b) = (self.local(p), self.local(q));
        let half = [self.half[0] + grow - EPS, self.half[1] + grow - EPS];
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for i in 0..2 {
            let d = b[i] - a[i];
            if d.abs() < 1e-12 {
                if a[i].abs() >= half[i] {
                    return false;
                }
                continue;
            }
            let (mut lo, mut hi) = ((-half[i] - a[i]) / d, (half[i] - a[i]) / d);
            if lo > hi {
                std::mem::swap(&mut lo, &mut hi);
            }
            t0 = t0.max(lo);
            t1 = t1.min(hi);
            if t0 >= t1 {
                return false;
            }
        }
        true
    }
}

/// Whether the segment `p`–`q` keeps `clearance` from every obstacle.
pub fn clear_of(p: [f64; 2], q: [f64; 2], obstacles: &[Obstacle], clearance: f64) -> bool {
    obstacles.iter().all(|o| !o.crossed_by(p, q, clearance))
}

/// How far (m) the segment `p`–`q` keeps from the nearest obstacle, up to `max` (to a
/// millimetre; 0 when it crosses one).
pub fn clearance_of(p: [f64; 2], q: [f64; 2], obstacles: &[Obstacle], max: f64) -> f64 {
    if clear_of(p, q, obstacles, max) {
        return max;
    }
    let (mut lo, mut hi) = (0.0, max);
    while hi - lo > 1e-3 {
        let mid = 0.5 * (lo + hi);
        if clear_of(p, q, obstacles, mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Slack (m) so that segments along a grown rectangle's sides and through its corners count as
/// clear.
const EPS: f64 = 1e-6;

/// The corners are placed this much (m) outside the grown rectangles, so that a way through one
/// does not graze the next.
const CORNER_SLACK: f64 = 1e-3;

/// The shortest way from `from` to `to` that keeps `clearance` from every obstacle, as the points
/// to pass through after `from` (ending with `to`); `None` if there is none. A straight way gives
/// `[to]`.
pub fn route(from: [f64; 2], to: [f64; 2], obstacles: &[Obstacle], clearance: f64) -> Option<Vec<[f64; 2]>> {
    route_within(from, to, obstacles, clearance, None)
}

/// [`route`] with the points passed through (not `from` or `to`) inside `region`, (min x, min y),
/// (max x, max y) when given: over the table, not over the robot's body beside it. A region that is
/// convex keeps every segment between two such points inside it.
pub fn route_within(
    from: [f64; 2],
    to: [f64; 2],
    obstacles: &[Obstacle],
    clearance: f64,
    region: Option<[[f64; 2]; 2]>,
) -> Option<Vec<[f64; 2]>> {
    if !(from.iter().chain(&to).all(|x| x.is_finite()) && clearance.is_finite()) {
        return None;
    }
    let inside = |c: [f64; 2]| region.is_none_or(|[lo, hi]| (0..2).all(|i| c[i] >= lo[i] && c[i] <= hi[i]));
    // Nodes: from, to, then the grown corners that lie outside every grown rectangle (and in the
    // region).
    let mut nodes = vec![from, to];
    for o in obstacles {
        for c in o.corners(clearance + CORNER_SLACK) {
            if inside(c) && !obstacles.iter().any(|p| p.contains(c, clearance)) {
                nodes.push(c);
            }
        }
    }
    // An end point inside a grown rectangle may leave it by its own segment, coming no nearer the
    // obstacle than the point itself is.
    let room = |p: [f64; 2]| -> Vec<f64> { obstacles.iter().map(|o| o.room(p).clamp(0.0, clearance)).collect() };
    let (room_from, room_to) = (room(from), room(to));
    let clear = |i: usize, j: usize| {
        obstacles.iter().enumerate().all(|(k, o)| {
            let mut grow = clearance;
            if i == 0 || j == 0 {
                grow = grow.min(room_from[k]);
            }
            if i == 1 || j == 1 {
                grow = grow.min(room_to[k]);
            }
            !o.crossed_by(nodes[i], nodes[j], grow)
        })
    };
    let n = nodes.len();
    let dist = |i: usize, j: usize| (nodes[i][0] - nodes[j][0]).hypot(nodes[i][1] - nodes[j][1]);
    let mut best = vec![f64::INFINITY; n];
    let mut prev = vec![usize::MAX; n];
    let mut done = vec![false; n];
    best[0] = 0.0;
    loop {
        let u = (0..n)
            .filter(|&i| !done[i] && best[i].is_finite())
            .min_by(|&a, &b| best[a].total_cmp(&best[b]))?;
        if u == 1 {
            break;
        }
        done[u] = true;
        for v in 0..n {
            if done[v] || v == u {
                continue;
            }
            let d = best[u] + dist(u, v);
            if d < best[v] && clear(u, v) {
                best[v] = d;
                prev[v] = u;
            }
        }
    }
    let mut way = vec![nodes[1]];
    let mut at = prev[1];
    while at != 0 {
        way.push(nodes[at]);
        at = prev[at];
    }
    way.reverse();
    Some(way)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn post() -> Obstacle {
        // A 22 × 6 cm post, its long side along y, at (0.55, −0.1).
        Obstacle {
            center: [0.55, -0.1],
            major_axis: [0.0, 1.0],
            half: [0.11, 0.03],
            top: f64::INFINITY,
        }
    }

    fn length(from: [f64; 2], way: &[[f64; 2]]) -> f64 {
        let mut at = from;
        let mut l = 0.0;
        for p in way {
            l += (p[0] - at[0]).hypot(p[1] - at[1]);
            at = *p;
        }
        l
    }

    #[test]
    fn the_union_of_two_views_of_a_post_holds_both() {
        // Two cut views of the post: its near and its far half, each measured 11 cm long.
        let near = Obstacle {
            center: [0.55, -0.155],
            half: [0.055, 0.03],
            top: 1.2,
            ..post()
        };
        let far = Obstacle {
            center: [0.55, -0.045],
            half: [0.055, 0.03],
            top: 1.25,
            ..post()
        };
        let u = near.union(&far);
        assert!(
            (u.center[0] - 0.55).abs() < 1e-12 && (u.center[1] + 0.1).abs() < 1e-12,
            "{u:?}"
        );
        assert!(
            (u.half[0] - 0.11).abs() < 1e-12 && (u.half[1] - 0.03).abs() < 1e-12,
            "{u:?}"
        );
        assert_eq!(u.top, 1.25);
        // A turned view: the box along the longer one's axis holds its corners too.
        let turned = Obstacle {
            center: [0.6, -0.1],
            major_axis: [1.0, 0.0],
            half: [0.05, 0.02],
            top: 1.0,
        };
        let w = post().union(&turned);
        assert_eq!(w.major_axis, [0.0, 1.0]);
        assert!(
            (w.center[0] - 0.585).abs() < 1e-12 && (w.half[1] - 0.065).abs() < 1e-12,
            "{w:?}"
        );
        assert!((w.half[0] - 0.11).abs() < 1e-12, "{w:?}");
    }

    #[test]
    fn a_clear_way_is_straight() {
        assert_eq!(route([0.4, 0.3], [0.8, 0.3], &[post()], 0.1), Some(vec![[0.8, 0.3]]));
        assert_eq!(route([0.4, 0.3], [0.8, 0.3], &[], 0.1), Some(vec![[0.8, 0.3]]));
    }

    /// Across the post: the way goes round its nearer end, keeps the clearance all along, and is
    /// no longer than going round the far end.
    #[test]
    fn a_way_across_a_post_goes_round_its_nearer_end_with_the_clearance() {
        let (from, to, c) = ([0.35, -0.05], [0.75, -0.12], 0.1);
        let way = route(from, to, &[post()], c).unwrap();
        assert!(way.len() >= 2, "{way:?}");
        assert_eq!(*way.last().unwrap(), to);
        // Every segment keeps the clearance: sample it.
        let mut at = from;
        for p in &way {
            for i in 0..=100 {
                let s = f64::from(i) / 100.0;
                let q = [at[0] + s * (p[0] - at[0]), at[1] + s * (p[1] - at[1])];
                assert!(!post().contains(q, c - 1e-3), "{q:?} on {way:?}");
            }
            at = *p;
        }
        // The post spans y −0.21…0.01 (grown: −0.31…0.11); from y −0.05 the ends are 0.16 and
        // 0.26 away: the way passes y > 0.
        assert!(way[0][1] > 0.0, "{way:?}");
        assert!(length(from, &way) < 0.75, "{way:?}");
    }

    #[test]
    fn a_palm_stopped_against_the_post_may_leave_it() {
        let way = route([0.47, -0.1], [0.8, -0.1], &[post()], 0.1).unwrap();
        assert!(way.len() >= 2, "{way:?}");
        // A palm 5 cm from the post's end does not pass it at 3 cm on its way.
        let way = route([0.5, 0.06], [0.62, 0.03], &[post()], 0.1).unwrap();
        assert!(way.len() >= 2, "{way:?}");
    }

    #[test]
    fn the_clearance_of_a_segment_is_its_distance_to_the_nearest_obstacle() {
        // The post spans x 0.52…0.58: a segment along x = 0.7 keeps 12 cm.
        let c = clearance_of([0.7, -0.3], [0.7, 0.1], &[post()], 0.3);
        assert!((c - 0.12).abs() < 2e-3, "{c}");
        assert_eq!(clearance_of([0.7, -0.3], [0.7, 0.1], &[post()], 0.08), 0.08);
        assert_eq!(clearance_of([0.4, -0.1], [0.7, -0.1], &[post()], 0.3), 0.0);
    }

    #[test]
    fn ways_keep_to_the_region() {
        // The post across the way: the nearer way round passes x < 0.3, off the table.
        let post = Obstacle {
            center: [0.45, 0.0],
            major_axis: [1.0, 0.0],
            half: [0.1, 0.04],
            top: f64::INFINITY,
        };
        let free = route([0.45, 0.3], [0.45, -0.3], &[post], 0.1).unwrap();
        assert!(free.iter().any(|p| p[0] < 0.3), "{free:?}");
        let table = [[0.3, -0.7], [0.9, 0.7]];
        let kept = route_within([0.45, 0.3], [0.45, -0.3], &[post], 0.1, Some(table)).unwrap();
        assert!(kept.iter().all(|p| p[0] >= 0.3), "{kept:?}");
        assert!(clear_of([0.45, 0.3], kept[0], &[post], 0.1 - 1e-6));
        // No way inside: none.
        let narrow = [[0.3, -0.7], [0.6, 0.7]];
        assert!(route_within([0.45, 0.3], [0.45, -0.3], &[post], 0.1, Some(narrow)).is_none());
    }

    #[test]
    fn a_walled_in_goal_has_no_way() {
        let walls = [
            Obstacle {
                center: [1.0, 0.0],
                major_axis: [0.0, 1.0],
                half: [0.5, 0.01],
                top: f64::INFINITY,
            },
            Obstacle {
                center: [1.4, 0.0],
                major_axis: [0.0, 1.0],
                half: [0.5, 0.01],
                top: f64::INFINITY,
            },
            Obstacle {
                center: [1.2, 0.4],
                major_axis: [1.0, 0.0],
                half: [0.3, 0.01],
                top: f64::INFINITY,
            },
            Obstacle {
                center: [1.2, -0.4],
                major_axis: [1.0, 0.0],
                half: [0.3, 0.01],
                top: f64::INFINITY,
            },
        ];
        assert_eq!(route([0.0, 0.0], [1.2, 0.0], &walls, 0.05), None);
        assert_eq!(route([0.0, 0.0], [f64::NAN, 0.0], &walls, 0.05), None);
    }
}
