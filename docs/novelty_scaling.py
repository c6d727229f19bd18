"""Does the way the novelty scales each joint decide whether the per-arm gate follows people it
has not seen? (docs/experiment-report-people.md)

Leaves each training person of data/demos/people.mcap out in turn (never its test people, never
another maker's capture): the other training people's frames are the reference poses, each arm's
threshold follows 10 % of 2,000 poses drawn within data/urdf/human.urdf's limits (the shipped
per-arm rule), and a frame is followed where both arms' novelty is within theirs. Prints, per
scaling, the left-out person's followed share (mean and worst person) and the random frames'.

    python docs/novelty_scaling.py
"""
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import sgplvm

ROOT = Path(__file__).resolve().parent.parent
data = sgplvm.load_demonstrations(ROOT / "data/demos/people.mcap")
human = data["human"]["positions"]
names = data["human"]["joint_names"]
person = np.empty(len(human), dtype=object)
for s in data["segments"]:
    person[s["start"]:s["end"]] = s["person"]
train = data["train"]
limits = {
    j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
    for j in ET.parse(ROOT / "data/urdf/human.urdf").getroot().iter("joint")
    if j.find("limit") is not None
}
lo = np.array([limits[n][0] for n in names])
hi = np.array([limits[n][1] for n in names])
random_poses = lo + (hi - lo) * np.random.default_rng(0).random((2000, 18))
ARMS = [np.arange(9), np.arange(9, 18)]


def novelty(reference, frames, scale):
    """Distance to the nearest reference pose, each joint in units of `scale` (RMS over joints)."""
    a, b = reference / scale, frames / scale
    d2 = (b**2).sum(1)[:, None] + (a**2).sum(1)[None, :] - 2 * b @ a.T
    return np.sqrt(np.maximum(d2.min(1), 0) / reference.shape[1])


SCALINGS = {
    "training spread, floor 0.05 rad (shipped)": lambda ref, c: np.maximum(ref.std(0), 0.05),
    "training spread, floor 0.1 rad": lambda ref, c: np.maximum(ref.std(0), 0.1),
    "training spread, floor 0.2 rad": lambda ref, c: np.maximum(ref.std(0), 0.2),
    "radians": lambda ref, c: np.ones(len(c)),
    "joint range": lambda ref, c: (hi - lo)[c],
    "spread and a tenth of the range": lambda ref, c: np.hypot(ref.std(0), 0.1 * (hi - lo)[c]),
}


def followed(scaling, reference, frames, share=0.10):
    ok = np.ones(len(frames), bool)
    rnd = np.ones(len(random_poses), bool)
    for cols in ARMS:
        ref = reference[:, cols]
        scale = scaling(ref, cols)
        threshold = np.quantile(novelty(ref, random_poses[:, cols], scale), share)
        ok &= novelty(ref, frames[:, cols], scale) <= threshold
        rnd &= novelty(ref, random_poses[:, cols], scale) <= threshold
    return ok.mean(), rnd.mean()


people = sorted(set(person[train]))
print(f"training people left out in turn: {', '.join(people)}")
for label, scaling in SCALINGS.items():
    rates, randoms = [], []
    for p in people:
        reference = human[train][person[train] != p]
        left_out = human[train][person[train] == p]
        rate, rnd = followed(scaling, reference, left_out)
        rates.append(rate)
        randoms.append(rnd)
    print(
        f"{label:42s} left-out person followed {100 * np.mean(rates):5.1f} % "
        f"(worst {100 * min(rates):5.1f} %), random frames {100 * np.mean(randoms):.2f} %"
    )
