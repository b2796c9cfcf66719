//! Pose correction on simulated sequences: a static object's box in frame t − 1, moved by the
//! relative ego pose read back from `poses.txt`, lands on its box in frame t (to 1 cm); moving
//! objects do not (so the check can fail).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use starnet_data::geometry::{Pose, read_poses, wrap_angle};
use starnet_data::kitti::read_sidecar;
use starnet_data::seed::sub_seed;
use starnet_sim::{SynthConfig, World, synth_sequences};

#[test]
fn pose_correction_maps_static_boxes_onto_the_next_frame() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (seed, length) = (11, 4);
    let cfg = SynthConfig::default();
    synth_sequences(dir.path(), 1, length, seed, &cfg, &|| {}).expect("sequence written");
    // The simulator's own truth about which objects stand still.
    let world = World::generate(
        &cfg.lidar,
        length as f32 * cfg.frame_interval,
        &mut ChaCha8Rng::seed_from_u64(sub_seed(seed, 2, 0)),
    );
    let still = |track: u32| world.actors.iter().any(|a| a.track_id == track && a.speed == 0.0);
    let seq = dir.path().join("sequences/0000");
    let poses = read_poses(&seq.join("poses.txt")).expect("poses parse");
    assert_eq!(poses.len(), length);
    let labels = |t: usize| read_sidecar(&seq.join(format!("training/label_360/{t:06}.txt"))).expect("sidecar");
    let (mut static_checked, mut moving_off) = (0, 0);
    for t in 1..length {
        let rel = Pose::between(&poses[t - 1], &poses[t]);
        assert!(rel.t[0].hypot(rel.t[1]) > 0.3, "the ego moves between frames");
        let (before, now) = (labels(t - 1), labels(t));
        for o in &before {
            let Some(n) = now.iter().find(|n| n.track_id == o.track_id) else {
                continue;
            };
            let m = rel.apply_box(&o.b);
            let off = (m.x - n.b.x).hypot(m.y - n.b.y).hypot(m.z - n.b.z);
            if still(o.track_id) {
                assert!(off < 0.01, "track {} off by {off} m", o.track_id);
                assert!(wrap_angle(m.heading - n.b.heading).abs() < 1e-3);
                static_checked += 1;
            } else if off > 0.1 {
                moving_off += 1;
            }
        }
    }
    assert!(static_checked >= 5, "only {static_checked} static boxes compared");
    assert!(moving_off >= 1, "no moving object to tell the check apart");
}
