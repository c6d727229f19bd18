//! A whole scene written at once ([`write_scene`], [`write_scene_with_markers`]): every body's
//! series and every array checked, then written atomically (temporary file and rename), frames
//! encoded on a thread of their own while the calling thread compresses and writes them, each
//! marker array after the last frame before its time.

use std::path::Path;
use std::sync::mpsc;

use super::body::SceneBody;
use super::channels::ArrayTopic;
use super::frame::EncodedFrame;
use super::markers::TimedMarkers;
use super::writer::{SceneOptions, SceneWriter};
use crate::joint_state::{write_atomically, JointStateError, JointStates, Result};

/// One body's joint states, for [`write_scene`].
#[derive(Debug, Clone, Copy)]
pub struct SceneSeries<'a> {
    /// The body.
    pub body: &'a SceneBody,
    /// Its joint states (the same times for every body of a scene).
    pub states: &'a JointStates,
}

/// One array topic's values, for [`write_scene`]: `values` is row-major, `len` per frame.
#[derive(Debug, Clone, Copy)]
pub struct ArraySeries<'a> {
    /// The topic.
    pub topic: &'a ArrayTopic,
    /// Row-major values, one row per frame.
    pub values: &'a [f64],
}

/// Frames encoded per batch while [`write_scene_with_markers`] writes the batch before.
pub(super) const ENCODE_BATCH: usize = 64;

/// Writes a whole scene to `path` atomically (temporary sibling, then rename). Every body's
/// series and every array must have one row per frame of the first body's times.
pub fn write_scene(
    path: impl AsRef<Path>,
    series: &[SceneSeries<'_>],
    arrays: &[ArraySeries<'_>],
    options: &SceneOptions,
) -> Result<()> {
    write_scene_with_markers(path, series, arrays, &[], options)
}

/// [`write_scene`] with marker arrays besides, each written after the last frame before its
/// time (so that a file read in log-time order meets the descriptions and `/tf_static`
/// first).
pub fn write_scene_with_markers(
    path: impl AsRef<Path>,
    series: &[SceneSeries<'_>],
    arrays: &[ArraySeries<'_>],
    markers: &[TimedMarkers],
    options: &SceneOptions,
) -> Result<()> {
    let path = path.as_ref();
    let mut order: Vec<&TimedMarkers> = markers.iter().collect();
    order.sort_by_key(|m| m.time_ns);
    let times = series.first().map_or(&[][..], |s| &s.states.times_ns[..]);
    for s in series {
        s.states
            .validate(&format!("topic `{}`", s.body.joint_topic))?;
        if s.states.times_ns != times {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", s.body.joint_topic),
                detail: "its times differ from the first body's".into(),
            });
        }
    }
    for a in arrays {
        if a.values.len() != times.len() * a.topic.len {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", a.topic.topic),
                detail: format!(
                    "{} values for {} frames × {}",
                    a.values.len(),
                    times.len(),
                    a.topic.len
                ),
            });
        }
    }
    let bodies: Vec<(SceneBody, Vec<String>)> = series
        .iter()
        .map(|s| (s.body.clone(), s.states.names.clone()))
        .collect();
    let topics: Vec<ArrayTopic> = arrays.iter().map(|a| a.topic.clone()).collect();
    write_atomically(path, |tmp| {
        let mut w = SceneWriter::create_as(tmp, path, bodies, topics, options, false)?;
        if let Some(&t0) = times.first() {
            w.write_static(t0)?;
        }
        let SceneWriter { encoder, sink, .. } = &mut w;
        // One thread encodes batches of frames while this one writes (and compresses) them;
        // written batches go back to be refilled, so the buffers are allocated once.
        let (batches, encoded) = mpsc::sync_channel::<Result<Vec<EncodedFrame>>>(2);
        let (recycle, written) = mpsc::channel::<Vec<EncodedFrame>>();
        std::thread::scope(|scope| {
            scope.spawn(move || {
                let mut joints: Vec<&[f64]> = Vec::with_capacity(series.len());
                let mut values: Vec<&[f64]> = Vec::with_capacity(arrays.len());
                for start in (0..times.len()).step_by(ENCODE_BATCH) {
                    let end = (start + ENCODE_BATCH).min(times.len());
                    let mut batch = written.try_recv().unwrap_or_default();
                    batch.resize_with(end - start, EncodedFrame::default);
                    let mut done = Ok(());
                    for (i, frame) in (start..end).zip(batch.iter_mut()) {
                        joints.clear();
                        joints.extend(series.iter().map(|s| s.states.row(i)));
                        values.clear();
                        values.extend(
                            arrays
                                .iter()
                                .map(|a| &a.values[i * a.topic.len..(i + 1) * a.topic.len]),
                        );
                        done = encoder.encode(i as u32, times[i], &joints, &values, frame);
                        if done.is_err() {
                            break;
                        }
                    }
                    let failed = done.is_err();
                    // A closed channel means the writer stopped on an error of its own.
                    if batches.send(done.map(|()| batch)).is_err() || failed {
                        return;
                    }
                }
            });
            for batch in encoded {
                let batch = batch?;
                for frame in &batch {
                    sink.write_frame(frame)?;
                    let i = sink.frames as usize;
                    let until = times.get(i).copied().unwrap_or(i64::MAX);
                    while let Some(m) = order.first().filter(|m| m.time_ns < until) {
                        sink.write_markers(m)?;
                        order.remove(0);
                    }
                }
                // The encoder may have finished: then nobody takes the batch back.
                let _ = recycle.send(batch);
            }
            Ok::<(), JointStateError>(())
        })?;
        if let Some(m) = order.first() {
            return Err(JointStateError::InvalidInput {
                what: format!("topic `{}`", m.topic),
                detail: "markers in a scene without frames".into(),
            });
        }
        w.finish()
    })
}
