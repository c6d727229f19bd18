//! The experiment's data as it travels to other processes: [`ExperimentData::to_json`] and
//! [`ExperimentData::from_json`], matrices row-major with their shape (floats round-trip exactly).

use serde::{Deserialize, Serialize};
use sgplvm_core::{Mat, MatRef};

use crate::experiment::{
    AllFrames, ExperimentData, ExperimentError, PartsData, RetargetingData, SplitData,
};

/// A matrix as it travels in JSON (row-major values).
#[derive(Serialize, Deserialize)]
struct MatrixJson {
    rows: usize,
    cols: usize,
    values: Vec<f64>,
}

impl MatrixJson {
    fn from(m: MatRef<'_, f64>) -> Self {
        MatrixJson {
            rows: m.nrows(),
            cols: m.ncols(),
            values: (0..m.nrows())
                .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
                .collect(),
        }
    }

    fn into_mat(self, what: &str) -> Result<Mat<f64>, String> {
        if self.rows.checked_mul(self.cols) != Some(self.values.len()) {
            return Err(format!(
                "{what}: {} values; expected rows × cols = {} × {}",
                self.values.len(),
                self.rows,
                self.cols
            ));
        }
        let cols = self.cols;
        Ok(Mat::from_fn(self.rows, cols, |i, j| {
            self.values[i * cols + j]
        }))
    }
}

#[derive(Serialize, Deserialize)]
struct SplitJson {
    train: MatrixJson,
    test: MatrixJson,
}

#[derive(Serialize, Deserialize)]
struct DataJson {
    input_name: String,
    human: SplitJson,
    robots: Vec<(String, SplitJson)>,
    validation: Vec<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    all_frames: Option<AllFramesJson>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    parts: Option<PartsData>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    retargeting: Option<RetargetingData>,
}

/// [`AllFrames`] as it travels in JSON.
#[derive(Serialize, Deserialize)]
struct AllFramesJson {
    human: MatrixJson,
    robots: Vec<MatrixJson>,
    validation: Vec<usize>,
}

impl AllFramesJson {
    fn from(a: &AllFrames) -> Self {
        AllFramesJson {
            human: MatrixJson::from(a.human.as_ref()),
            robots: a
                .robots
                .iter()
                .map(|m| MatrixJson::from(m.as_ref()))
                .collect(),
            validation: a.validation.clone(),
        }
    }

    fn into_all_frames(self) -> Result<AllFrames, String> {
        Ok(AllFrames {
            human: self.human.into_mat("all_frames.human")?,
            robots: self
                .robots
                .into_iter()
                .enumerate()
                .map(|(k, m)| m.into_mat(&format!("all_frames.robots[{k}]")))
                .collect::<Result<_, String>>()?,
            validation: self.validation,
        })
    }
}

impl SplitJson {
    fn from(s: &SplitData) -> Self {
        SplitJson {
            train: MatrixJson::from(s.train.as_ref()),
            test: MatrixJson::from(s.test.as_ref()),
        }
    }

    fn into_split(self, what: &str) -> Result<SplitData, String> {
        Ok(SplitData {
            train: self.train.into_mat(&format!("{what}.train"))?,
            test: self.test.into_mat(&format!("{what}.test"))?,
        })
    }
}

impl ExperimentData {
    /// The data as JSON (exact: floats round-trip), to send to other processes.
    pub fn to_json(&self) -> Vec<u8> {
        let data = DataJson {
            input_name: self.input_name.clone(),
            human: SplitJson::from(&self.human),
            robots: self
                .robots
                .iter()
                .map(|(n, s)| (n.clone(), SplitJson::from(s)))
                .collect(),
            validation: self.validation.clone(),
            all_frames: self.all_frames.as_ref().map(AllFramesJson::from),
            parts: self.parts.clone(),
            retargeting: self.retargeting.clone(),
        };
        // Finite matrices and plain fields: serialising cannot fail.
        serde_json::to_vec(&data).unwrap_or_default()
    }

    /// The data back from [`ExperimentData::to_json`].
    pub fn from_json(bytes: &[u8]) -> Result<Self, ExperimentError> {
        let bad = |problem: String| ExperimentError::Task {
            context: "experiment data".into(),
            problem,
        };
        let data: DataJson = serde_json::from_slice(bytes).map_err(|e| bad(e.to_string()))?;
        let robots = data
            .robots
            .into_iter()
            .map(|(n, s)| {
                let split = s.into_split(&format!("robots.{n}"))?;
                Ok((n, split))
            })
            .collect::<Result<Vec<_>, String>>()
            .map_err(bad)?;
        let all_frames = data
            .all_frames
            .map(AllFramesJson::into_all_frames)
            .transpose()
            .map_err(bad)?;
        Ok(ExperimentData {
            input_name: data.input_name,
            human: data.human.into_split("human").map_err(bad)?,
            robots,
            validation: data.validation,
            all_frames,
            parts: data.parts,
            retargeting: data.retargeting,
        })
    }
}
