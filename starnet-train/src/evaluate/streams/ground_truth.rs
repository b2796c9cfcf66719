//! [`StreamGroundTruth`]: the labelled objects a streaming evaluation scores against.

use crate::Result;
use starnet_data::kitti::KittiDataset;
use starnet_eval::metrics::WaymoObject;
use starnet_eval::waymo_objects;

/// The ground truth of a streaming evaluation: per frame id, its labelled objects (with their
/// LiDAR point counts) within `stream.eval_range`. Computed once, shared by every model and n.
#[derive(Debug, Clone)]
pub struct StreamGroundTruth {
    /// `(frame id, objects)` in split order.
    pub frames: Vec<(String, Vec<WaymoObject>)>,
}

impl StreamGroundTruth {
    /// Reads the first `max_frames` frames of `dataset` (all when `None`), keeping the objects
    /// within `eval_range` metres of the sensor.
    pub fn read(eval_range: f32, dataset: &KittiDataset, max_frames: Option<usize>) -> Result<Self> {
        let ids = &dataset.ids()[..max_frames.map_or(dataset.ids().len(), |m| m.min(dataset.ids().len()))];
        let frames = ids
            .iter()
            .map(|id| {
                let frame = dataset.load(id)?;
                let objects = waymo_objects(&frame)
                    .into_iter()
                    .filter(|o| o.b.x.hypot(o.b.y) <= eval_range)
                    .collect();
                Ok((id.clone(), objects))
            })
            .collect::<Result<_>>()?;
        Ok(Self { frames })
    }
}
