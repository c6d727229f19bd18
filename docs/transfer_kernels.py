"""Why trained transfers do worse on new motions than their starting kernel (docs/fidelity.md):
walkman's validated model (shipped data) transferred to COMAN and CENTAURO with the starting
kernel, the kernel trained to convergence, and each half of the change swapped in with
`set_params`; test and held-out (validation) MSE of each.

    python docs/transfer_kernels.py
"""

import copy

import numpy as np

import sgplvm

d = sgplvm.load_demonstrations("data/demos/bimanual.mcap")
tr, te, val = d["train"], d["test"], d["validation"]
H = d["human"]["positions"]
R = {r: d["robots"][r]["positions"] for r in d["robots"]}


def mse(model, robot, rows_h, rows_r):
    return float(np.mean((model.predict(rows_h, robot) - rows_r) ** 2))


source = sgplvm.SharedGPLVM(5, "input", 0).fit({"human": H[tr], "walkman": R["walkman"][tr]}, validation=val)
for t in ["coman", "centauro"]:
    start = source.transfer(t, R[t][tr], max_iters=0, validation=None).params["spaces"][t]
    trained_model = source.transfer(t, R[t][tr], max_iters=1000, validation=None)
    trained = trained_model.params["spaces"][t]
    print(t, "start", start, "\n  trained", trained)
    for label, kernel in [
        ("starting kernel", start),
        ("trained kernel", trained),
        ("trained lengthscales, starting noise", dict(trained, noise=start["noise"])),
        ("starting lengthscales, trained noise", dict(start, noise=trained["noise"])),
    ]:
        params = copy.deepcopy(trained_model.params)
        params["spaces"][t] = kernel
        m = sgplvm.SharedGPLVM.from_bytes(trained_model.to_bytes())
        m.set_params(params)
        print(
            f"  {label:38} test {mse(m, t, H[te], R[t][te]):.4f}"
            f"  held out {mse(m, t, H[tr][val], R[t][tr][val]):.4f}"
        )
