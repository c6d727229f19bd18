//! Every frame of the training motions, not only the subsampled training set: what the models
//! that scale linearly in the frames (the sparse and the Bayesian one) train on.
//!
//! A dataset stores its training set subsampled (the paper's every 12th frame) and its segments
//! whole. The training motions at full rate are the frames of the segments that hold training
//! frames and no test frame, less the guard frames a block split left out next to a test
//! block ([`crate::retarget::split::SplitOptions::guard_s`]): the file does not store the guard, so it
//! is read off the test blocks, whose first test frame is their first frame past the guard
//! (test frames are subsampled from there). A segment holding test frames too contributes its
//! training frames only, so no frame near a test frame is added.

use super::{Dataset, Segment};

impl Dataset {
    /// Every frame of the training motions (increasing): the subsampled training set
    /// [`Dataset::train`] is a subset of it, no test frame is in it, and no frame the split
    /// left out as a guard between a training and a test block (see the module docs). For the
    /// generated demonstrations, the training set the generator writes with `train_subsample`
    /// 1; for a block split, every frame of its training blocks but their guards. Without
    /// segments, the training set itself.
    pub fn every_training_frame(&self) -> Vec<usize> {
        if self.segments.is_empty() {
            return self.train.clone();
        }
        let guard = self.guard_ns();
        let mut frames = Vec::with_capacity(self.len());
        for (k, segment) in self.segments.iter().enumerate() {
            let own = self.frames_in(&self.train, segment);
            if own.is_empty() {
                continue;
            }
            if !self.frames_in(&self.test, segment).is_empty() {
                frames.extend_from_slice(own);
                continue;
            }
            let guarded_before = k
                .checked_sub(1)
                .is_some_and(|p| self.tests_next_to(&self.segments[p], segment));
            let guarded_after = self
                .segments
                .get(k + 1)
                .is_some_and(|n| self.tests_next_to(n, segment));
            let (t_start, t_end) = (self.times_ns[segment.start], self.times_ns[segment.end - 1]);
            // `≤`: the split compares seconds as floating-point numbers, so a frame exactly
            // one guard from a boundary is left out in some blocks and kept in others; it is
            // left out here wherever it might have been.
            // It stays when it is in the training set.
            let near = |d: i64| guard > 0 && d <= guard;
            frames.extend((segment.start..segment.end).filter(|&i| {
                let t = self.times_ns[i];
                !(guarded_before && near(t - t_start) || guarded_after && near(t_end - t))
                    || own.binary_search(&i).is_ok()
            }));
        }
        frames
    }

    /// This dataset with [`Dataset::every_training_frame`] as its training set (everything
    /// else unchanged), so that [`Dataset::validation_split`] and [`Dataset::training_groups`]
    /// hold out the same motions at full rate.
    pub fn with_every_training_frame(&self) -> Dataset {
        Dataset {
            train: self.every_training_frame(),
            ..self.clone()
        }
    }

    /// The frames of `set` (increasing) within `segment`.
    fn frames_in<'a>(&self, set: &'a [usize], segment: &Segment) -> &'a [usize] {
        let from = set.partition_point(|&f| f < segment.start);
        let to = set.partition_point(|&f| f < segment.end);
        &set[from..to]
    }

    /// Whether `other`, a neighbour of `segment` on the clock (no gap: the two are of one
    /// recording), holds test frames.
    fn tests_next_to(&self, other: &Segment, segment: &Segment) -> bool {
        !other.is_empty() && !self.frames_in(&self.test, other).is_empty() && {
            let (a, b) = if other.start < segment.start {
                (other.end - 1, segment.start)
            } else {
                (segment.end - 1, other.start)
            };
            self.times_ns[b] - self.times_ns[a] <= 2 * self.frame_interval_ns()
        }
    }

    /// The median time between consecutive frames (0 with fewer than two frames).
    fn frame_interval_ns(&self) -> i64 {
        let mut steps: Vec<i64> = self.times_ns.windows(2).map(|w| w[1] - w[0]).collect();
        if steps.is_empty() {
            return 0;
        }
        let mid = steps.len() / 2;
        *steps.select_nth_unstable(mid).1
    }

    /// The guard a block split left out at the boundaries between training and test blocks:
    /// the longest time from the start of a test segment that follows a training segment
    /// without a gap to its first test frame (0 when there is none, as in generated data, whose
    /// test frames start with their motion).
    fn guard_ns(&self) -> i64 {
        self.segments
            .windows(2)
            .filter(|w| {
                self.frames_in(&self.test, &w[0]).is_empty()
                    && !self.frames_in(&self.train, &w[0]).is_empty()
                    && self.tests_next_to(&w[1], &w[0])
            })
            .map(|w| {
                let first = self.frames_in(&self.test, &w[1])[0];
                self.times_ns[first] - self.times_ns[w[1].start]
            })
            .max()
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::BodyData;
    use crate::retarget::split::{split_into_blocks, SplitOptions, SplitRule};
    use nalgebra::DMatrix;

    fn body(name: &str, n: usize) -> BodyData {
        BodyData {
            name: name.into(),
            topic: format!("/{name}/joint_states"),
            joint_names: vec![format!("{name}_j")],
            positions: DMatrix::from_fn(n, 1, |i, _| i as f64),
        }
    }

    /// Two recordings of 40 Hz frames, 1 s apart, as one dataset of two unlabelled segments.
    fn recordings(lengths: [usize; 2]) -> Dataset {
        let mut times = Vec::new();
        let mut segments = Vec::new();
        for len in lengths {
            let start = times.len();
            let t0 = times.last().map_or(0, |t| t + 1_000_000_000);
            times.extend((0..len as i64).map(|k| t0 + k * 25_000_000));
            segments.push(Segment {
                start,
                end: times.len(),
                from_pose: None,
                to_pose: None,
                repetition: None,
                person: None,
            });
        }
        let n = times.len();
        Dataset {
            times_ns: times,
            human: body("human", n),
            robots: vec![body("robot", n)],
            pose_names: Vec::new(),
            segments,
            train: (0..n).collect(),
            test: Vec::new(),
        }
    }

    /// After a block split, every frame of the training blocks but their guards: the frames
    /// the same split keeps for training without subsampling, but for those exactly one guard
    /// from a boundary.
    #[test]
    fn a_block_split_gives_its_training_blocks_at_full_rate_without_the_guards() {
        for (guard_s, test_every, lengths) in [
            (0.5, 4, [500, 330]),
            (0.3, 3, [400, 401]),
            (0.0, 2, [250, 170]),
        ] {
            let options = |train_subsample| SplitOptions {
                rule: SplitRule::Blocks { test_every },
                block_s: 2.0,
                guard_s,
                train_subsample,
                test_subsample: 3,
                min_train_frames: 0,
            };
            let mut sub = recordings(lengths);
            split_into_blocks(&mut sub, &options(12)).expect("split");
            let mut full = recordings(lengths);
            split_into_blocks(&mut full, &options(1)).expect("split");
            let every = sub.every_training_frame();
            // Nothing the split left out; of what it kept, at most the frame exactly a guard
            // from each boundary between a training and a test block.
            let missing = full
                .train
                .iter()
                .filter(|f| every.binary_search(f).is_err())
                .count();
            assert!(
                every.iter().all(|f| full.train.binary_search(f).is_ok()),
                "guard {guard_s}, every {test_every}: a frame the split left out"
            );
            let test_blocks = sub
                .segments
                .iter()
                .filter(|s| sub.test.iter().any(|&t| s.start <= t && t < s.end))
                .count();
            let limit = if guard_s > 0.0 { 2 * test_blocks } else { 0 };
            assert!(
                missing <= limit,
                "guard {guard_s}: {missing} frames missing"
            );
            assert!(every.len() > 10 * sub.train.len());
            assert!(sub.train.iter().all(|f| every.binary_search(f).is_ok()));
            assert!(sub.test.iter().all(|f| every.binary_search(f).is_err()));
            let with = sub.with_every_training_frame();
            assert_eq!(with.train, every);
            assert_eq!(with.test, sub.test);
            with.validate().expect("valid");
        }
    }

    /// A segment holding test frames gives its training frames only; without segments the
    /// training set is returned as it is.
    #[test]
    fn mixed_segments_and_no_segments() {
        let mut ds = recordings([40, 40]);
        ds.train = (0..40).step_by(4).collect();
        ds.test = (40..80).step_by(2).collect();
        ds.train.extend([41, 43]);
        ds.test.retain(|&f| f != 41 && f != 43);
        // Segment 0 at full rate (the next segment is 1 s later: not its neighbour on the
        // clock); segment 1 holds test frames: its two training frames only.
        let mut expected: Vec<usize> = (0..40).collect();
        expected.extend([41, 43]);
        assert_eq!(ds.every_training_frame(), expected);
        ds.segments.clear();
        assert_eq!(ds.every_training_frame(), ds.train);
    }
}
