//! Ray-cast rendering of parry shapes: one primary ray per pixel, Lambert shading with one
//! directional light plus ambient, seeded Gaussian pixel noise.
//!
//! Culling: every frame each item whose local AABB is not wholly outside the viewing frustum gets a
//! conservative pixel rectangle (the AABB projected; the whole image if the AABB reaches behind the
//! camera) and a lower bound on its distance from the camera centre (distance to that AABB). Items are
//! sorted by that bound and binned into 8×8-pixel tiles; a pixel only tests the items of its tile
//! whose rectangle holds it, nearest bound first, and stops as soon as the best hit is nearer than
//! the next item's bound. Boxes, cylinders and balls are intersected analytically (parry casts
//! cylinders with GJK, ~10× slower); other shapes by parry after a ray–bounding-sphere test. The
//! pixels' unit rays in the optical frame are computed once per set of intrinsics and kept (the
//! same arithmetic as computing them per frame: images are bit-identical).

use crate::convert::iso_to_glam;
use crate::error::SimError;
use crate::geometry::{support_half_extent, to_parry};
use crate::scene::{ColorPatch, LightSpec, Scene, Shape};
use crate::vision::color::hsv_to_rgb;
use crate::vision::noise::Gaussian;
use control_basis::hardware::{Camera, MAX_IMAGE_SIDE};
use control_basis::math::{Iso3, Vec3};
use parry3d_f64::glamx::{DMat3, DPose3, DVec3};
use parry3d_f64::query::Ray;
use parry3d_f64::shape::SharedShape;

/// What a pixel shows, for the robot self-filter and for tests' ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ItemLabel {
    /// Part of the empty scene (table, bins): belongs in the background image.
    Static,
    /// A link of the robot itself.
    Robot,
    /// A movable object, with an identifier chosen by the caller (e.g. its placement index).
    Object(usize),
    /// An obstacle put on the table during a run (a blocked-arm fault): not part of the
    /// background, seen like any other thing.
    Obstacle(usize),
}

/// Surface colour of a render item.
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    /// One colour, HSV `[h_deg, s, v]`.
    Uniform([f64; 3]),
    /// Horizontal colour bands along the object's local z, bottom to top, each as tall as its
    /// `fraction` of `z_max − z_min` (see [`ColorPatch`]).
    Bands {
        /// The patches, bottom first. Fractions are renormalised to sum 1.
        patches: Vec<ColorPatch>,
        /// Lowest object-frame z of the shape.
        z_min: f64,
        /// Highest object-frame z of the shape.
        z_max: f64,
    },
}

impl Material {
    /// The material for a catalog shape with `colors` (one patch → [`Material::Uniform`]).
    pub fn for_shape(shape: &Shape, colors: &[ColorPatch]) -> Self {
        match colors {
            [] => Material::Uniform([0.0, 0.0, 0.5]),
            [one] => Material::Uniform(one.hsv),
            _ => {
                let h = support_half_extent(shape, &Vec3::z());
                Material::Bands {
                    patches: colors.to_vec(),
                    z_min: -h,
                    z_max: h,
                }
            }
        }
    }

    /// The RGB colour ([0, 1]) at object-frame height `z`.
    pub fn rgb_at(&self, z: f64) -> [f64; 3] {
        match self {
            Material::Uniform(hsv) => hsv_to_rgb(*hsv),
            Material::Bands { patches, z_min, z_max } => hsv_to_rgb(band_at(patches, *z_min, *z_max, z)),
        }
    }
}

fn band_at(patches: &[ColorPatch], z_min: f64, z_max: f64, z: f64) -> [f64; 3] {
    let Some(last) = patches.last() else {
        return [0.0, 0.0, 0.5];
    };
    let total: f64 = patches.iter().map(|p| p.fraction.max(0.0)).sum();
    let span = z_max - z_min;
    if !(total > 0.0 && span > 0.0) {
        return patches[0].hsv;
    }
    let f = ((z - z_min) / span).clamp(0.0, 1.0) * total;
    let mut acc = 0.0;
    for p in patches {
        acc += p.fraction.max(0.0);
        if f < acc {
            return p.hsv;
        }
    }
    last.hsv
}

/// One shape to render.
#[derive(Debug, Clone)]
pub struct RenderItem {
    /// The parry shape.
    pub shape: SharedShape,
    /// Pose of the shape in the world (`world_from_object * object_from_shape`).
    pub world_from_shape: Iso3,
    /// Pose of the shape in its object's frame (from [`crate::geometry::to_parry`]); used to find
    /// the object-frame z of a surface point for [`Material::Bands`].
    pub object_from_shape: Iso3,
    /// Surface colour.
    pub material: Material,
    /// What the item is.
    pub label: ItemLabel,
}

impl RenderItem {
    /// A catalog shape with its colour patches at `world_from_object`.
    pub fn from_catalog(shape: &Shape, world_from_object: Iso3, colors: &[ColorPatch], label: ItemLabel) -> Self {
        let (parry, object_from_shape) = to_parry(shape);
        Self {
            shape: parry,
            world_from_shape: world_from_object * object_from_shape,
            object_from_shape,
            material: Material::for_shape(shape, colors),
            label,
        }
    }

    /// A single-coloured box (full side lengths `size`) at `world_from_box`.
    pub fn uniform_box(size: [f64; 3], world_from_box: Iso3, hsv: [f64; 3], label: ItemLabel) -> Self {
        Self {
            shape: SharedShape::cuboid(0.5 * size[0], 0.5 * size[1], 0.5 * size[2]),
            world_from_shape: world_from_box,
            object_from_shape: Iso3::identity(),
            material: Material::Uniform(hsv),
            label,
        }
    }

    /// Moves the item: `world_from_shape = world_from_object * object_from_shape`.
    pub fn set_object_pose(&mut self, world_from_object: &Iso3) {
        self.world_from_shape = world_from_object * self.object_from_shape;
    }

    /// The pose of the item's object frame in the world.
    pub fn world_from_object(&self) -> Iso3 {
        self.world_from_shape * self.object_from_shape.inverse()
    }
}

/// The shapes a camera sees. The caller updates poses in place each frame.
#[derive(Debug, Clone, Default)]
pub struct RenderScene {
    /// The items.
    pub items: Vec<RenderItem>,
}

/// Thickness of the table slab built by [`RenderScene::from_scene`] (m), as in the physics scene.
pub const TABLE_THICKNESS: f64 = 0.04;
/// Floor thickness of bins and marked regions built by [`RenderScene::from_scene`] (m), as in the
/// physics scene.
pub const BIN_FLOOR_THICKNESS: f64 = 0.002;

impl RenderScene {
    /// An empty scene.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an item, returning its index.
    pub fn push(&mut self, item: RenderItem) -> usize {
        self.items.push(item);
        self.items.len() - 1
    }

    /// The index of the item labelled `label`, if any.
    pub fn find(&self, label: ItemLabel) -> Option<usize> {
        self.items.iter().position(|i| i.label == label)
    }

    /// The static scene and the objects of a resolved [`Scene`], with the geometry the physics
    /// scene uses: the table (a slab of [`TABLE_THICKNESS`] below its top), each place (a floor
    /// plate of its inner size, plus four walls of `wall_thickness` outside it if it has walls), all
    /// [`ItemLabel::Static`]; then each placed object `k` as [`ItemLabel::Object`]`(k)` at its
    /// resting pose (the simulator moves them with [`RenderItem::set_object_pose`]). Robot links are
    /// the caller's to add ([`ItemLabel::Robot`]).
    pub fn from_scene(scene: &Scene) -> Self {
        let mut out = Self::new();
        let t = &scene.spec.table;
        let top = t.height;
        let at = |x: f64, y: f64, z: f64| Iso3::translation(x, y, z);
        out.push(RenderItem::uniform_box(
            [t.size[0], t.size[1], TABLE_THICKNESS],
            at(t.center[0], t.center[1], top - 0.5 * TABLE_THICKNESS),
            t.hsv,
            ItemLabel::Static,
        ));
        for p in &scene.spec.places {
            let [cx, cy] = p.center;
            let [sx, sy] = p.size;
            out.push(RenderItem::uniform_box(
                [sx, sy, BIN_FLOOR_THICKNESS],
                at(cx, cy, top + 0.5 * BIN_FLOOR_THICKNESS),
                p.hsv,
                ItemLabel::Static,
            ));
            if p.wall_height > 0.0 {
                // Walls of `wall_thickness` outside the inner size; the x walls cover the corners.
                let (w, h) = (p.wall_thickness, p.wall_height);
                let zc = top + 0.5 * h;
                let walls = [
                    ([w, sy + 2.0 * w, h], [cx + 0.5 * (sx + w), cy]),
                    ([w, sy + 2.0 * w, h], [cx - 0.5 * (sx + w), cy]),
                    ([sx, w, h], [cx, cy + 0.5 * (sy + w)]),
                    ([sx, w, h], [cx, cy - 0.5 * (sy + w)]),
                ];
                for (size, [x, y]) in walls {
                    out.push(RenderItem::uniform_box(size, at(x, y, zc), p.hsv, ItemLabel::Static));
                }
            }
        }
        for (k, r) in scene.resolved.iter().enumerate() {
            if let Some(spec) = scene.catalog.objects.get(r.object) {
                out.push(RenderItem::from_catalog(
                    &spec.shape,
                    r.pose,
                    &spec.colors,
                    ItemLabel::Object(k),
                ));
            }
        }
        out
    }
}

pub use control_basis::hardware::Image;

/// Counters of the last frame, for performance work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Items that passed culling (in front of the camera, overlapping the image).
    pub items_drawn: usize,
    /// Ray–bounding-sphere pre-tests (all shapes but boxes).
    pub sphere_tests: u64,
    /// Exact ray–shape intersections (analytic for boxes, cylinders and balls, parry otherwise).
    pub ray_casts: u64,
}

/// How a cached item is intersected.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Box with these half extents: slab test.
    Cuboid(DVec3),
    /// Parry cylinder (axis y): half height, radius. Parry casts these with GJK; analytic is ~10× faster.
    Cylinder(f64, f64),
    /// Ball of this radius about the shape origin: the bounding-sphere test is the exact hit.
    Ball,
    /// Anything else: parry's ray cast.
    Generic,
}

/// Per-frame facts about one item.
#[derive(Debug, Clone)]
struct Cached {
    item: u32,
    pose: DPose3,
    /// Rotation of `pose` and its inverse as matrices.
    rot: DMat3,
    inv_rot: DMat3,
    /// The camera centre in the shape frame.
    origin_local: DVec3,
    kind: Kind,
    /// Present for banded materials: maps world points to the object frame.
    object_from_world: Option<DPose3>,
    rgb: [f64; 3],
    /// Inclusive pixel rectangle u0, v0, u1, v1.
    rect: [u32; 4],
    /// Lower bound of the hit distance along any unit ray from the camera centre.
    near: f64,
    sphere_center: DVec3,
    sphere_r2: f64,
}

const TILE: u32 = 8;
/// Items nearer to the camera centre than this (in the optical z) make the rectangle unbounded.
const NEAR_PLANE: f64 = 1e-3;

/// Renders images of a [`RenderScene`] from a [`Camera`]. Owns its image, label, depth and culling
/// buffers, reused from frame to frame (no allocation after the first frame of a given size and
/// scene size).
#[derive(Debug, Clone)]
pub struct Renderer {
    pixel_noise: f64,
    ambient: f64,
    /// Unit direction the light travels.
    light_dir: DVec3,
    background_rgb: [f64; 3],
    seed: u64,
    noise: Gaussian,
    image: Image,
    labels: Vec<Option<ItemLabel>>,
    depth: Vec<f32>,
    cache: Vec<Cached>,
    tile_start: Vec<u32>,
    tile_fill: Vec<u32>,
    tile_items: Vec<u32>,
    /// Per pixel the unit ray direction in the optical frame and the inverse length of its
    /// `z = 1` form (the depth of a hit at unit distance), for the intrinsics in `rays_for`.
    rays: Vec<(DVec3, f64)>,
    rays_for: [u64; 6],
    stats: RenderStats,
}

/// Colour of pixels whose ray hits nothing (the floor far below, the room), RGB in [0, 1].
pub const DEFAULT_BACKGROUND_RGB: [f64; 3] = [0.12, 0.12, 0.14];

impl Renderer {
    /// A renderer with Gaussian pixel noise of standard deviation `pixel_noise` (on RGB in [0, 1]),
    /// lit by `light`, its noise fixed by `seed`.
    pub fn new(pixel_noise: f64, light: &LightSpec, seed: u64) -> Result<Self, SimError> {
        if !(pixel_noise.is_finite() && pixel_noise >= 0.0) {
            return Err(SimError::Invalid {
                path: "<camera>".into(),
                field: "camera.pixel_noise".into(),
                message: format!("{pixel_noise} is not a finite value >= 0"),
            });
        }
        let d = DVec3::from_array(light.direction);
        let len = d.length();
        if !(len.is_finite() && len > 1e-12) {
            return Err(SimError::Invalid {
                path: "<light>".into(),
                field: "light.direction".into(),
                message: format!("{:?} is not a direction", light.direction),
            });
        }
        if !(0.0..=1.0).contains(&light.ambient) {
            return Err(SimError::Invalid {
                path: "<light>".into(),
                field: "light.ambient".into(),
                message: format!("{} is not in [0, 1]", light.ambient),
            });
        }
        Ok(Self {
            pixel_noise,
            ambient: light.ambient,
            light_dir: d / len,
            background_rgb: DEFAULT_BACKGROUND_RGB,
            seed,
            noise: Gaussian::new(seed),
            image: Image::default(),
            labels: Vec::new(),
            depth: Vec::new(),
            cache: Vec::new(),
            tile_start: Vec::new(),
            tile_fill: Vec::new(),
            tile_items: Vec::new(),
            rays: Vec::new(),
            rays_for: [0; 6],
            stats: RenderStats::default(),
        })
    }

    /// Restarts the noise sequence from `seed`.
    pub fn reseed(&mut self, seed: u64) {
        self.seed = seed;
        self.noise = Gaussian::new(seed);
    }

    /// The seed given at construction or by the last [`Renderer::reseed`].
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Sets the colour of pixels that hit nothing (RGB in [0, 1]).
    pub fn set_background_rgb(&mut self, rgb: [f64; 3]) {
        self.background_rgb = rgb.map(|c| if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 });
    }

    /// The last rendered image.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// Per pixel (row-major) the label of the item hit, `None` where the ray hits nothing.
    pub fn labels(&self) -> &[Option<ItemLabel>] {
        &self.labels
    }

    /// Per pixel (row-major) the depth (optical z, m) of the hit, `f32::INFINITY` where none.
    pub fn depth(&self) -> &[f32] {
        &self.depth
    }

    /// Counters of the last frame.
    pub fn stats(&self) -> RenderStats {
        self.stats
    }

    /// Renders every item of `scene`.
    pub fn render(&mut self, camera: &Camera, scene: &RenderScene) -> Result<&Image, SimError> {
        self.render_filtered(camera, scene, |_| true)
    }

    /// Renders only the [`ItemLabel::Static`] items: the background image of the empty scene.
    pub fn render_background(&mut self, camera: &Camera, scene: &RenderScene) -> Result<&Image, SimError> {
        self.render_filtered(camera, scene, |l| l == ItemLabel::Static)
    }

    /// Renders the items whose label passes `include`.
    pub fn render_filtered(
        &mut self,
        camera: &Camera,
        scene: &RenderScene,
        include: impl Fn(ItemLabel) -> bool,
    ) -> Result<&Image, SimError> {
        check_camera(camera)?;
        let (w, h) = (camera.width, camera.height);
        let n = camera.pixel_count();
        self.image.resize(w, h);
        self.labels.resize(n, None);
        self.depth.resize(n, f32::INFINITY);
        self.stats = RenderStats::default();

        let cam = iso_to_glam(&camera.world_from_optical);
        self.build_cache(camera, &cam, scene, include);
        self.bin_tiles(w, h);
        self.trace(camera, &cam, scene);
        Ok(&self.image)
    }

    fn build_cache(&mut self, camera: &Camera, cam: &DPose3, scene: &RenderScene, include: impl Fn(ItemLabel) -> bool) {
        self.cache.clear();
        let origin = cam.translation;
        let full = [0, 0, camera.width - 1, camera.height - 1];
        let (w_edge, h_edge) = (camera.width as f64, camera.height as f64);
        for (i, item) in scene.items.iter().enumerate() {
            if !include(item.label) {
                continue;
            }
            let pose = iso_to_glam(&item.world_from_shape);
            if !pose.is_finite() || item.shape.contains_point(&pose, origin) {
                // Non-finite poses are skipped; a shape holding the camera centre is its housing.
                continue;
            }
            let aabb = item.shape.compute_local_aabb();
            let (lo, hi) = (aabb.mins, aabb.maxs);
            // Distance from the camera centre to the local AABB: a lower bound on any hit distance.
            let o = pose.inverse_transform_point(origin);
            let near = (lo - o).max(o - hi).max(DVec3::ZERO).length();
            // Conservative pixel rectangle from the projected AABB corners.
            let (mut umin, mut umax, mut vmin, mut vmax) =
                (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
            let (mut any_front, mut any_behind) = (false, false);
            let mut outside = [0u32; 4];
            for k in 0..8 {
                let c = DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let p = cam.inverse_transform_point(pose * c);
                // Side planes of the viewing frustum (one pixel of margin), as half-spaces through
                // the camera centre: an item whose corners are all outside one of them is invisible.
                outside[0] += (camera.fx * p.x + (camera.cx + 1.0) * p.z < 0.0) as u32;
                outside[1] += (camera.fx * p.x - (w_edge - camera.cx) * p.z > 0.0) as u32;
                outside[2] += (camera.fy * p.y + (camera.cy + 1.0) * p.z < 0.0) as u32;
                outside[3] += (camera.fy * p.y - (h_edge - camera.cy) * p.z > 0.0) as u32;
                if p.z < NEAR_PLANE {
                    any_behind = true;
                    continue;
                }
                any_front = true;
                let (u, v) = (camera.fx * p.x / p.z + camera.cx, camera.fy * p.y / p.z + camera.cy);
                umin = umin.min(u);
                umax = umax.max(u);
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            }
            if !any_front || outside.contains(&8) {
                continue;
            }
            let rect = if any_behind {
                full
            } else {
                // Pixel centres k with umin <= k <= umax, widened by one pixel for rounding.
                let (u0, u1) = (umin.ceil() - 1.0, umax.floor() + 1.0);
                let (v0, v1) = (vmin.ceil() - 1.0, vmax.floor() + 1.0);
                if u1 < 0.0 || v1 < 0.0 || u0 > full[2] as f64 || v0 > full[3] as f64 {
                    continue;
                }
                let cl = |x: f64, m: u32| x.clamp(0.0, m as f64) as u32;
                [cl(u0, full[2]), cl(v0, full[3]), cl(u1, full[2]), cl(v1, full[3])]
            };
            let sphere = item.shape.compute_local_bounding_sphere();
            let object_from_world = match item.material {
                Material::Bands { .. } => {
                    Some(iso_to_glam(&(item.object_from_shape * item.world_from_shape.inverse())))
                }
                Material::Uniform(_) => None,
            };
            let kind = if let Some(c) = item.shape.as_cuboid() {
                Kind::Cuboid(c.half_extents)
            } else if let Some(c) = item.shape.as_cylinder() {
                Kind::Cylinder(c.half_height, c.radius)
            } else if item.shape.as_ball().is_some() && sphere.center == DVec3::ZERO {
                Kind::Ball
            } else {
                Kind::Generic
            };
            let rot = DMat3::from_quat(pose.rotation);
            self.cache.push(Cached {
                item: i as u32,
                pose,
                rot,
                inv_rot: rot.transpose(),
                origin_local: o,
                kind,
                object_from_world,
                rgb: item.material.rgb_at(0.0),
                rect,
                near,
                sphere_center: pose * sphere.center,
                sphere_r2: sphere.radius * sphere.radius,
            });
        }
        self.cache
            .sort_unstable_by(|a, b| a.near.total_cmp(&b.near).then(a.item.cmp(&b.item)));
        self.stats.items_drawn = self.cache.len();
    }

    /// Bins the cached items (already in near order) into tiles: a CSR list per tile.
    fn bin_tiles(&mut self, w: u32, h: u32) {
        let (tx, ty) = (w.div_ceil(TILE) as usize, h.div_ceil(TILE) as usize);
        self.tile_start.clear();
        self.tile_start.resize(tx * ty + 1, 0);
        for c in &self.cache {
            let [u0, v0, u1, v1] = c.rect;
            for ty_ in (v0 / TILE) as usize..=(v1 / TILE) as usize {
                for tx_ in (u0 / TILE) as usize..=(u1 / TILE) as usize {
                    self.tile_start[ty_ * tx + tx_ + 1] += 1;
                }
            }
        }
        for t in 0..tx * ty {
            self.tile_start[t + 1] += self.tile_start[t];
        }
        self.tile_fill.clear();
        self.tile_fill.extend_from_slice(&self.tile_start[..tx * ty]);
        self.tile_items.resize(self.tile_start[tx * ty] as usize, 0);
        for (ci, c) in self.cache.iter().enumerate() {
            let [u0, v0, u1, v1] = c.rect;
            for ty_ in (v0 / TILE) as usize..=(v1 / TILE) as usize {
                for tx_ in (u0 / TILE) as usize..=(u1 / TILE) as usize {
                    let slot = &mut self.tile_fill[ty_ * tx + tx_];
                    self.tile_items[*slot as usize] = ci as u32;
                    *slot += 1;
                }
            }
        }
    }

    /// Fills [`Renderer::rays`] for `camera`'s intrinsics (kept while they do not change).
    fn optical_rays(&mut self, camera: &Camera) {
        let key = [
            camera.width as u64,
            camera.height as u64,
            camera.fx.to_bits(),
            camera.fy.to_bits(),
            camera.cx.to_bits(),
            camera.cy.to_bits(),
        ];
        if key == self.rays_for && self.rays.len() == camera.pixel_count() {
            return;
        }
        let (ifx, ify) = (1.0 / camera.fx, 1.0 / camera.fy);
        self.rays.clear();
        for v in 0..camera.height {
            let yo = (v as f64 - camera.cy) * ify;
            for u in 0..camera.width {
                let d_opt = DVec3::new((u as f64 - camera.cx) * ifx, yo, 1.0);
                let inv_norm = 1.0 / d_opt.length();
                self.rays.push((d_opt * inv_norm, inv_norm));
            }
        }
        self.rays_for = key;
    }

    fn trace(&mut self, camera: &Camera, cam: &DPose3, scene: &RenderScene) {
        self.optical_rays(camera);
        let (w, h) = (camera.width, camera.height);
        let tx = w.div_ceil(TILE) as usize;
        let origin = cam.translation;
        let sigma = self.pixel_noise;
        let mut stats = self.stats;
        for v in 0..h {
            for u in 0..w {
                let pix = v as usize * w as usize + u as usize;
                let (d_unit, inv_norm) = self.rays[pix];
                let dir = cam.rotation * d_unit;
                let t_idx = (v / TILE) as usize * tx + (u / TILE) as usize;
                let (s, e) = (self.tile_start[t_idx] as usize, self.tile_start[t_idx + 1] as usize);
                let mut best_t = f64::INFINITY;
                let mut best: Option<(usize, DVec3)> = None;
                for &ci in &self.tile_items[s..e] {
                    let c = &self.cache[ci as usize];
                    if c.near >= best_t {
                        break;
                    }
                    let [u0, v0, u1, v1] = c.rect;
                    if u < u0 || u > u1 || v < v0 || v > v1 {
                        continue;
                    }
                    let hit = match c.kind {
                        Kind::Cuboid(half) => {
                            // The slab test is as cheap as a bounding-sphere test: no pre-test.
                            stats.ray_casts += 1;
                            ray_box(c.origin_local, c.inv_rot * dir, half, best_t).map(|(t, n)| (t, c.rot * n))
                        }
                        _ => {
                            stats.sphere_tests += 1;
                            let oc = c.sphere_center - origin;
                            let b = oc.dot(dir);
                            let disc = b * b - (oc.length_squared() - c.sphere_r2);
                            if disc < 0.0 {
                                continue;
                            }
                            let sq = disc.sqrt();
                            if b + sq < 0.0 || b - sq >= best_t {
                                continue;
                            }
                            stats.ray_casts += 1;
                            match c.kind {
                                Kind::Ball => {
                                    let t = (b - sq).max(0.0);
                                    Some((t, (origin + dir * t - c.sphere_center).normalize_or_zero()))
                                }
                                Kind::Cylinder(hh, r) => ray_cylinder(c.origin_local, c.inv_rot * dir, hh, r, best_t)
                                    .map(|(t, n)| (t, c.rot * n)),
                                _ => scene.items[c.item as usize]
                                    .shape
                                    .cast_ray_and_get_normal(&c.pose, &Ray::new(origin, dir), best_t, true)
                                    .map(|h| (h.time_of_impact, h.normal)),
                            }
                        }
                    };
                    if let Some((t, normal)) = hit
                        && t < best_t
                    {
                        best_t = t;
                        best = Some((ci as usize, normal));
                    }
                }
                let (rgb, label, depth) = match best {
                    None => (self.background_rgb, None, f32::INFINITY),
                    Some((ci, normal)) => {
                        let c = &self.cache[ci];
                        let item = &scene.items[c.item as usize];
                        let base = match (&item.material, c.object_from_world) {
                            (Material::Bands { patches, z_min, z_max }, Some(ofw)) => {
                                let z = (ofw * (origin + dir * best_t)).z;
                                hsv_to_rgb(band_at(patches, *z_min, *z_max, z))
                            }
                            _ => c.rgb,
                        };
                        let n = if normal.dot(dir) > 0.0 { -normal } else { normal };
                        let lambert = (-n.dot(self.light_dir)).max(0.0);
                        let shade = self.ambient + (1.0 - self.ambient) * lambert;
                        (base.map(|x| x * shade), Some(item.label), (best_t * inv_norm) as f32)
                    }
                };
                let out = &mut self.image.rgb[3 * pix..3 * pix + 3];
                for (o, x) in out.iter_mut().zip(rgb) {
                    let noisy = if sigma > 0.0 {
                        x + sigma * self.noise.sample()
                    } else {
                        x
                    };
                    // Round half up; `as u8` saturates (and maps NaN to 0).
                    *o = (noisy * 255.0 + 0.5) as u8;
                }
                self.labels[pix] = label;
                self.depth[pix] = depth;
            }
        }
        self.stats = stats;
    }
}

/// First hit of the ray `o + t·d` (`t` in `[0, max_t)`) with the solid box of half extents `half`
/// (slab method): `(t, outward normal)`. A ray starting inside hits at `t = 0`.
fn ray_box(o: DVec3, d: DVec3, half: DVec3, max_t: f64) -> Option<(f64, DVec3)> {
    let inv = d.recip();
    let t1 = (-half - o) * inv;
    let t2 = (half - o) * inv;
    let (tmin, tmax) = (t1.min(t2), t1.max(t2));
    let t_near = tmin.max_element();
    let t_far = tmax.min_element();
    if t_near.is_nan() || t_near > t_far || t_far < 0.0 || t_near >= max_t {
        return None;
    }
    if t_near < 0.0 {
        return Some((0.0, -d));
    }
    let n = if t_near == tmin.x {
        DVec3::new(-d.x.signum(), 0.0, 0.0)
    } else if t_near == tmin.y {
        DVec3::new(0.0, -d.y.signum(), 0.0)
    } else {
        DVec3::new(0.0, 0.0, -d.z.signum())
    };
    Some((t_near, n))
}

/// First hit of the ray `o + t·d` (`d` unit, `t` in `[0, max_t)`) with the solid cylinder of axis
/// y, half height `hh` and radius `r` (parry's convention): `(t, outward normal)`. A ray starting
/// inside hits at `t = 0`.
fn ray_cylinder(o: DVec3, d: DVec3, hh: f64, r: f64, max_t: f64) -> Option<(f64, DVec3)> {
    let r2 = r * r;
    let inside_radially = o.x * o.x + o.z * o.z <= r2;
    if inside_radially && o.y.abs() <= hh {
        return Some((0.0, -d));
    }
    let mut best: Option<(f64, DVec3)> = None;
    // Lateral surface.
    let a = d.x * d.x + d.z * d.z;
    if a > 1e-15 && !inside_radially {
        let b = o.x * d.x + o.z * d.z;
        let c = o.x * o.x + o.z * o.z - r2;
        let disc = b * b - a * c;
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            if t >= 0.0 && t < max_t {
                let y = o.y + t * d.y;
                if y.abs() <= hh {
                    let p = o + d * t;
                    best = Some((t, DVec3::new(p.x / r, 0.0, p.z / r)));
                }
            }
        }
    }
    // The cap facing the ray origin.
    if d.y.abs() > 1e-15 && o.y.abs() > hh {
        let cap = hh.copysign(o.y);
        let t = (cap - o.y) / d.y;
        if t >= 0.0 && t < best.map_or(max_t, |b| b.0) {
            let (x, z) = (o.x + t * d.x, o.z + t * d.z);
            if x * x + z * z <= r2 {
                best = Some((t, DVec3::new(0.0, 1.0f64.copysign(o.y), 0.0)));
            }
        }
    }
    best
}

/// Checks that a camera can be rendered: image size in range, finite positive focal lengths,
/// finite principal point and pose.
pub fn check_camera(camera: &Camera) -> Result<(), SimError> {
    let bad = |field: &str, message: String| SimError::Invalid {
        path: "<camera>".into(),
        field: field.into(),
        message,
    };
    for (field, side) in [("camera.width", camera.width), ("camera.height", camera.height)] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return Err(bad(field, format!("{side} px is not in 1..={MAX_IMAGE_SIDE}")));
        }
    }
    if !(camera.fx.is_finite() && camera.fx > 0.0 && camera.fy.is_finite() && camera.fy > 0.0) {
        return Err(bad(
            "camera.fx",
            format!("focal lengths {} / {} must be finite and > 0", camera.fx, camera.fy),
        ));
    }
    if !(camera.cx.is_finite() && camera.cy.is_finite()) {
        return Err(bad("camera.cx", "principal point is not finite".into()));
    }
    let p = &camera.world_from_optical;
    if !(p.translation.vector.iter().all(|x| x.is_finite()) && p.rotation.coords.iter().all(|x| x.is_finite())) {
        return Err(bad("camera.pose", "the pose is not finite".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convert::iso_to_glam;
    use bayes::rng::Draw;
    use control_basis::math::iso_from_xyz_rpy;

    /// The per-pixel rays are kept while the intrinsics stay and rebuilt when they change: a
    /// renderer that drew another camera first draws exactly what a fresh one draws.
    #[test]
    fn cached_rays_follow_the_intrinsics() {
        use crate::scene::{CameraSpec, LightSpec};
        use crate::vision::fixtures::{TABLE_FIXATION, head_cameras, typical_scene};
        let (scene, _) = typical_scene(3, 6, true);
        // Another size, then the same size with a narrower field of view (other focal lengths).
        let small = CameraSpec {
            width: 80,
            height: 60,
            ..CameraSpec::default()
        };
        let narrow = CameraSpec {
            hfov_deg: 45.0,
            ..CameraSpec::default()
        };
        let a = head_cameras(&small, Vec3::from(TABLE_FIXATION)).unwrap().left;
        let a2 = head_cameras(&narrow, Vec3::from(TABLE_FIXATION)).unwrap().left;
        let b = head_cameras(&CameraSpec::default(), Vec3::from(TABLE_FIXATION))
            .unwrap()
            .right;
        let mut reused = Renderer::new(0.01, &LightSpec::default(), 9).unwrap();
        reused.render(&a, &scene).unwrap();
        reused.render(&a2, &scene).unwrap();
        reused.reseed(9);
        let mut fresh = Renderer::new(0.01, &LightSpec::default(), 9).unwrap();
        for _ in 0..2 {
            let img = reused.render(&b, &scene).unwrap().clone();
            assert_eq!(&img, fresh.render(&b, &scene).unwrap());
            assert_eq!(reused.depth(), fresh.depth());
        }
    }

    /// The slab box cast agrees with parry's.
    #[test]
    fn box_cast_matches_parry() {
        let shape = SharedShape::cuboid(0.05, 0.02, 0.07);
        let pose = iso_to_glam(&iso_from_xyz_rpy([0.6, 0.05, 0.82], [0.3, -0.7, 1.1]));
        let origin = DVec3::new(0.05, 0.06, 1.5);
        let mut rng = bayes::rng::seeded(4);
        let mut hits = 0;
        for _ in 0..4000 {
            let target =
                pose.translation + DVec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 0.2;
            let dir = (target - origin).normalize();
            let parry = shape.cast_ray_and_get_normal(&pose, &Ray::new(origin, dir), f64::INFINITY, true);
            let ours = ray_box(
                pose.inverse_transform_point(origin),
                pose.rotation.inverse() * dir,
                DVec3::new(0.05, 0.02, 0.07),
                10.0,
            )
            .map(|(t, n)| (t, pose.rotation * n));
            assert_eq!(parry.is_some(), ours.is_some());
            if let (Some(p), Some((t, n))) = (parry, ours) {
                hits += 1;
                assert!((p.time_of_impact - t).abs() < 1e-12);
                assert!((p.normal - n).length() < 1e-9);
            }
        }
        assert!(hits > 500);
        // starting inside
        assert_eq!(ray_box(DVec3::ZERO, DVec3::X, DVec3::ONE, 1.0).map(|h| h.0), Some(0.0));
    }

    /// The analytic cylinder cast agrees with parry's GJK cast.
    #[test]
    fn cylinder_cast_matches_parry() {
        let shape = SharedShape::cylinder(0.07, 0.03);
        let pose = iso_from_xyz_rpy([0.6, 0.05, 0.82], [0.3, -0.7, 1.1]);
        let gp = iso_to_glam(&pose);
        let origin = DVec3::new(0.05, 0.06, 1.5);
        let mut rng = bayes::rng::seeded(3);
        let (mut hits, mut both) = (0, 0);
        for _ in 0..4000 {
            let target =
                gp.translation + DVec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 0.2;
            let dir = (target - origin).normalize();
            let parry = shape.cast_ray_and_get_normal(&gp, &Ray::new(origin, dir), f64::INFINITY, true);
            let ours = ray_cylinder(
                gp.inverse_transform_point(origin),
                gp.rotation.inverse() * dir,
                0.07,
                0.03,
                f64::INFINITY,
            )
            .map(|(t, n)| (t, gp.rotation * n));
            match (parry, ours) {
                (Some(p), Some((t, n))) => {
                    both += 1;
                    assert!((p.time_of_impact - t).abs() < 1e-6, "{} vs {t}", p.time_of_impact);
                    assert!((p.normal - n).length() < 1e-3, "{:?} vs {n:?}", p.normal);
                }
                // Grazing rays may differ by GJK tolerance; they must at least be near the surface.
                (Some(p), None) => assert!(
                    p.time_of_impact > 0.0
                        && shape.distance_to_point(&gp, origin + dir * p.time_of_impact, true) < 1e-6
                ),
                (None, Some((t, _))) => assert!(shape.distance_to_point(&gp, origin + dir * t, true) < 1e-9),
                (None, None) => {}
            }
            hits += ours.is_some() as usize;
        }
        assert!(hits > 500 && both >= hits - 5, "{hits} {both}");
    }
}
