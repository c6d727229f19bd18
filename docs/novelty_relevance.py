"""Does weighing each human joint in the novelty by how much the robot's commands depend on it
let the per-arm gate follow people it has not seen? (docs/experiment-report-people.md)

Each joint's scale is its training spread (floored at 0.05 rad, as shipped) divided by its
relevance: the RMS change of the robot arm's retargeted joints per unit of that joint's spread,
from a GP regression per arm fitted on the reference frames (finite differences), relevances
averaging 1 and floored. Leave-one-CMU-person-out as docs/novelty_scaling.py (each arm's
threshold at 10 % of 2,000 random poses). Other captures (imported MCAP files) given after the
robot are judged against every training frame, for evaluation only.

    python docs/novelty_relevance.py [ROBOT [OTHER.mcap ...]]      (default walkman)
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
import numpy as np
import sgplvm
ROOT = Path(__file__).resolve().parent.parent
data = sgplvm.load_demonstrations(ROOT / "data/demos/people.mcap")
human = data["human"]["positions"]; names = data["human"]["joint_names"]
robot = sys.argv[1] if len(sys.argv) > 1 else "walkman"
R = data["robots"][robot]["positions"]; rnames = data["robots"][robot]["joint_names"]
person = np.empty(len(human), dtype=object)
for s in data["segments"]:
    person[s["start"]:s["end"]] = s["person"]
train = data["train"]
limits = {j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
          for j in ET.parse(ROOT / "data/urdf/human.urdf").getroot().iter("joint") if j.find("limit") is not None}
lo = np.array([limits[n][0] for n in names]); hi = np.array([limits[n][1] for n in names])
random_poses = lo + (hi - lo) * np.random.default_rng(0).random((2000, 18))
ARMS = [np.arange(9), np.arange(9, 18)]
RARMS = [np.array([i for i, n in enumerate(rnames) if n.upper().startswith("L")]),
         np.array([i for i, n in enumerate(rnames) if n.upper().startswith("R")])]

def novelty(reference, frames, scale):
    a, b = reference / scale, frames / scale
    d2 = (b**2).sum(1)[:, None] + (a**2).sum(1)[None, :] - 2 * b @ a.T
    return np.sqrt(np.maximum(d2.min(1), 0) / reference.shape[1])

def relevance(h, r):
    gp = sgplvm.GPRegression(max_iters=200).fit(h, r)
    pts = h[:: max(1, len(h) // 150)]
    spread = np.maximum(h.std(0), 0.05)
    s = np.zeros(h.shape[1])
    for j in range(h.shape[1]):
        e = np.zeros(h.shape[1]); e[j] = 1e-3
        d = (gp.predict(pts + e) - gp.predict(pts - e)) / 2e-3
        s[j] = np.sqrt((d**2).sum(1).mean()) * spread[j]
    return s / s.mean()

def followed(reference, rref, frames, mode, share=0.10):
    ok = np.ones(len(frames), bool); rnd = np.ones(len(random_poses), bool)
    for cols, rc in zip(ARMS, RARMS):
        ref = reference[:, cols]
        scale = np.maximum(ref.std(0), 0.05)
        if mode != "shipped":
            rel = relevance(ref, rref[:, rc])
            floor = {"relevance, floor 0.1": 0.1, "relevance, floor 0.3": 0.3}[mode]
            scale = scale / np.maximum(rel, floor)
        th = np.quantile(novelty(ref, random_poses[:, cols], scale), share)
        ok &= novelty(ref, frames[:, cols], scale) <= th
        rnd &= novelty(ref, random_poses[:, cols], scale) <= th
    return ok.mean(), rnd.mean()

people = sorted(set(person[train]))
for mode in ["shipped", "relevance, floor 0.1", "relevance, floor 0.3"]:
    rates, rnds = [], []
    for p in people:
        m = person[train] != p
        rate, rnd = followed(human[train][m], R[train][m], human[train][~m], mode)
        rates.append(rate); rnds.append(rnd)
    print(f"{robot} {mode:24s} left-out followed {100*np.mean(rates):5.1f} % (worst {100*min(rates):5.1f} %), random {100*np.mean(rnds):.2f} %", flush=True)

# Evaluation only (the choice is made on the CMU people above): other captures' frames against
# every training frame.
if len(sys.argv) > 2:
    other = np.concatenate([sgplvm.load_demonstrations(f)["human"]["positions"] for f in sys.argv[2:]])
    for mode in ["shipped", "relevance, floor 0.1"]:
        rate, rnd = followed(human[train], R[train], other, mode)
        print(f"{robot} other captures, {mode:24s} followed {100*rate:5.1f} %, random {100*rnd:.2f} %", flush=True)
