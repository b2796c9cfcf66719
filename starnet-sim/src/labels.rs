//! Labelling a simulated frame the way KITTI's annotators did, from what the simulator
//! measured: the ray-cast occlusion, and the projection of each box through a real KITTI camera
//! (2D box, truncation, alpha). `label_2` keeps KITTI's convention — objects visible in image 2
//! only, far ones as DontCare regions, DontCare last — while the sidecar keeps every object.

use starnet_data::kitti::SimObject;
use starnet_data::kitti::{Calib, ImageSize, KittiObject, ObjectClass, observation_angle};

/// Occlusion level from the share of an object's rays that something else blocked, KITTI's
/// 0 = fully visible, 1 = partly, 2 = largely occluded, 3 = unknown (too few rays to tell).
pub fn occlusion_level(rays_toward: u32, rays_hit: u32) -> i32 {
    if rays_toward < 4 {
        return 3;
    }
    let blocked = 1.0 - rays_hit as f32 / rays_toward as f32;
    if blocked <= 0.05 {
        0
    } else if blocked <= 0.7 {
        1
    } else {
        2
    }
}

/// Objects farther than this from the camera are DontCare regions, as in KITTI.
pub const DONT_CARE_DISTANCE: f32 = 80.0;
/// An object with at least this share of its rays blocked is invisible and gets no label. Below
/// it a sliver shows in the image, and KITTI's annotators labelled such objects (2.1 % of its
/// cars have no LiDAR point).
pub const INVISIBLE_BLOCKED: f32 = 0.995;

/// The camera's view of one object: its label line, or `None` if image 2 does not show it.
pub fn camera_label(obj: &SimObject, calib: &Calib, image: ImageSize) -> Option<KittiObject> {
    let cam = calib.box_to_label(&obj.b);
    let full = calib.projected_bbox(&cam)?;
    let bbox = calib.image_bbox(&cam, image)?;
    let area = |b: [f64; 4]| ((b[2] - b[0]) * (b[3] - b[1])).max(0.0);
    let clipped = area(bbox.map(f64::from));
    let truncated = (1.0 - clipped / area(full).max(1e-9)).clamp(0.0, 1.0) as f32;
    let blocked = if obj.rays_toward == 0 {
        0.0
    } else {
        1.0 - obj.rays_hit as f32 / obj.rays_toward as f32
    };
    if truncated > 0.8 || clipped < 1.0 || blocked >= INVISIBLE_BLOCKED {
        return None;
    }
    if cam.x.hypot(cam.z) > DONT_CARE_DISTANCE {
        return Some(KittiObject::dont_care(bbox));
    }
    Some(KittiObject {
        class: obj.class,
        truncated,
        occluded: obj.occlusion,
        alpha: observation_angle(&cam),
        bbox,
        cam,
        score: None,
    })
}

/// The `label_2` lines of a frame: the camera labels, DontCare regions last. Returns the lines
/// and, per object, whether it got a line (class or DontCare).
pub fn label_frame(objects: &[SimObject], calib: &Calib, image: ImageSize) -> (Vec<KittiObject>, Vec<bool>) {
    let per_object: Vec<Option<KittiObject>> = objects.iter().map(|o| camera_label(o, calib, image)).collect();
    let in_camera = per_object.iter().map(Option::is_some).collect();
    let mut lines: Vec<KittiObject> = per_object.into_iter().flatten().collect();
    lines.sort_by_key(|o| o.class == ObjectClass::DontCare);
    (lines, in_camera)
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::Box3d;

    fn obj(x: f32, y: f32) -> SimObject {
        SimObject {
            class: ObjectClass::Car,
            track_id: 0,
            b: Box3d::new(x, y, -0.97, 3.9, 1.6, 1.5, 0.0),
            num_points: 100,
            rays_toward: 100,
            rays_hit: 90,
            occlusion: 0,
            in_camera: false,
        }
    }

    #[test]
    fn occlusion_levels() {
        assert_eq!(occlusion_level(2, 0), 3);
        assert_eq!(occlusion_level(100, 96), 0);
        assert_eq!(occlusion_level(100, 80), 1);
        assert_eq!(occlusion_level(100, 50), 1);
        assert_eq!(occlusion_level(100, 10), 2);
    }

    #[test]
    fn camera_view_rules() {
        let calib = Calib::kitti_000000();
        let img = ImageSize::KITTI;
        let ahead = camera_label(&obj(20.0, 0.0), &calib, img).unwrap();
        assert_eq!(ahead.class, ObjectClass::Car);
        assert_eq!(ahead.truncated, 0.0);
        assert!((ahead.alpha - (ahead.cam.ry - ahead.cam.x.atan2(ahead.cam.z))).abs() < 1e-5);
        assert!(
            camera_label(&obj(-20.0, 0.0), &calib, img).is_none(),
            "behind the camera"
        );
        assert!(
            camera_label(&obj(5.0, 30.0), &calib, img).is_none(),
            "outside the image"
        );
        assert_eq!(
            camera_label(&obj(85.0, 0.0), &calib, img).unwrap().class,
            ObjectClass::DontCare
        );
        assert_eq!(
            camera_label(&obj(75.0, 0.0), &calib, img).unwrap().class,
            ObjectClass::Car
        );
        // At the edge of the image: partly truncated.
        let edge = camera_label(&obj(8.0, 6.5), &calib, img).unwrap();
        assert!(edge.truncated > 0.05 && edge.truncated < 0.8, "{}", edge.truncated);
        let hidden = SimObject {
            num_points: 0,
            rays_hit: 0,
            ..obj(20.0, 0.0)
        };
        let sliver = SimObject {
            num_points: 0,
            rays_hit: 1,
            ..obj(20.0, 0.0)
        };
        assert_eq!(
            camera_label(&sliver, &calib, img).unwrap().occluded,
            0,
            "levels come from the SimObject"
        );
        assert!(camera_label(&hidden, &calib, img).is_none(), "fully occluded");
    }
}
