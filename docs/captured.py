"""How captured motion differs from the generated demonstrations: measurements behind
docs/experiment-report-captured.md.

For each demonstration file (default: the shipped generated and captured ones) it prints

- the split: training and test frames, and how many motions (segments) each comes from;
- the spread of the human's angles (mean per-joint standard deviation over the training
  frames, rad) and the frame-to-frame noise (median absolute second difference of the 40 Hz
  angles over all frames, rad: a smooth motion has almost none, sensor noise adds it);
- how far the test motions are from the training ones: for every test frame, the distance to
  the nearest training frame in the human's joint space (rad), median and 90th percentile,
  beside the same for the training frames among themselves (leave-one-out);
- how consistent the robot's commands are with the human's pose: the mean squared error of
  predicting a test frame's robot joints by the nearest training frame's (nearest in the
  human's joint space), per robot, beside predicting the training mean. A deterministic,
  smooth mapping from the human's pose to the robot's joints gives a small first number.

The test frames are only measured here: nothing is chosen by them.

    python docs/captured.py [file.mcap ...]

Needs the sgplvm module (pip install .).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import sgplvm

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = [ROOT / "data/demos/bimanual.mcap", ROOT / "data/demos/captured.mcap"]


def nearest(a: np.ndarray, b: np.ndarray, leave_one_out: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """For each row of ``a``: the index of and the distance to the nearest row of ``b``."""
    d = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    if leave_one_out:
        np.fill_diagonal(d, np.inf)
    i = d.argmin(1)
    return i, np.sqrt(d[np.arange(len(a)), i])


def segments_of(frames: np.ndarray, segments: list[dict]) -> int:
    starts = np.array([s["start"] for s in segments])
    return len(np.unique(np.searchsorted(starts, frames, side="right")))


def describe(path: Path) -> None:
    demo = sgplvm.load_demonstrations(path)
    h = demo["human"]["positions"]
    train, test = demo["train"], demo["test"]
    print(f"== {path.name}: {len(demo['times_ns'])} frames; {len(train)} training frames from "
          f"{segments_of(train, demo['segments'])} motions, {len(test)} test frames from "
          f"{segments_of(test, demo['segments'])} motions")
    spread = h[train].std(0).mean()
    noise = np.median(np.abs(np.diff(h, n=2, axis=0)))
    print(f"human: spread {spread:.3f} rad, frame-to-frame noise {noise:.5f} rad")
    i, d = nearest(h[test], h[train])
    _, d_train = nearest(h[train], h[train], leave_one_out=True)
    print(f"test -> nearest training frame: median {np.median(d):.3f} rad, 90th percentile "
          f"{np.percentile(d, 90):.3f}; training frames among themselves: median {np.median(d_train):.3f}")
    for name, body in demo["robots"].items():
        r = body["positions"]
        by_neighbour = ((r[test] - r[train][i]) ** 2).mean()
        by_mean = ((r[test] - r[train].mean(0)) ** 2).mean()
        print(f"  {name:9s} test MSE by the nearest training frame {by_neighbour:.4f} rad², "
              f"by the training mean {by_mean:.4f} rad²")


if __name__ == "__main__":
    for p in sys.argv[1:] or DEFAULT:
        describe(Path(p))
