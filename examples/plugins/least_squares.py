#!/usr/bin/env python3
"""An aeroid plug-in in Python: equation error (ordinary least squares) on
the lateral-directional coefficients, with NumPy.

aeroid runs `python3 least_squares.py WORK`; WORK holds problem.json (the
estimation problem: parameters, the aircraft in SI, the records). This
writes WORK/estimate.json, or WORK/refusal.json when the problem is not one
it can solve. The protocol: docs/plugins.md.

The regression is aeroid's own equation error for the side force
(Klein & Morelli, "Aircraft System Identification", ch. 5): on the samples
of the record's common time base,

    CY = m·g0·ny / (q̄·S),   CY = CY_0 + CY_beta·β + CY_p·p̂ + CY_r·r̂ + CY_da·δa + CY_dr·δr,

p̂ = p·b/(2V), r̂ = r·b/(2V), θ = (XᵀX)⁻¹Xᵀz by least squares, σ² = eᵀe/(N − n),
Cov θ = σ²(XᵀX)⁻¹. The rolling and yawing moments need angular
accelerations: the record's p_dot and r_dot when it has them, else NumPy's
second-order central differences of p and r, leaving out the samples
next to a step in a control (a jump of more than 0.1° between samples),
where the angular accelerations jump and a difference smears the jump
(not aeroid's differentiator, so the moment estimates differ from
aeroid's within a few of their bounds).
"""

import json
import os
import sys

import numpy as np

G0 = 9.80665


def refuse(work, kind, **fields):
    with open(os.path.join(work, "refusal.json"), "w") as f:
        json.dump(dict(kind=kind, method=PROBLEM["method"], **fields), f)
    sys.exit(0)


def channel(record, name):
    for c in record["channels"]:
        if c["name"] == name:
            return np.array(c["times"], float), np.array(
                [np.nan if v is None else v for v in c["values"]], float)
    return None


def main(work):
    global PROBLEM
    with open(os.path.join(work, "problem.json")) as f:
        PROBLEM = problem = json.load(f)
    aircraft = problem["aircraft"]
    model = problem["model"]["structure"]["name"]
    record = problem["records"][0]
    wanted = ["airspeed", "beta", "p", "r", "ny", "aileron", "rudder", "dynamic_pressure"]
    data = {}
    missing = []
    for name in wanted:
        found = channel(record, name)
        if found is None:
            missing.append(dict(name=name, purpose="the lateral regression"))
        else:
            data[name] = found
    if missing:
        present = [c["name"] for c in record["channels"]]
        refuse(work, "missing-channels", channels=missing, present=present)
    times = data["ny"][0]
    if any(len(data[n][0]) != len(times) or np.any(data[n][0] != times) for n in data):
        refuse(work, "unsuitable-model", model=model,
               reason="this example needs every channel on one time base")
    if aircraft["rate_normalization"] != "2V":
        refuse(work, "unsuitable-model", model=model,
               reason="this example knows the 2V rate normalisation only")
    v = data["airspeed"][1]
    if aircraft["rate_speed"] == "reference":
        v = np.full_like(v, aircraft["reference_airspeed"])
    b, s, m = aircraft["span"], aircraft["wing_area"], aircraft["mass"]
    qbar = data["dynamic_pressure"][1]
    p, r = data["p"][1], data["r"][1]
    regressors = {
        "0": np.ones_like(times),
        "beta": data["beta"][1],
        "p": p * b / (2 * v),
        "r": r * b / (2 * v),
        "da": data["aileron"][1],
        "dr": data["rudder"][1],
    }

    def acceleration(name, rate):
        found = channel(record, name + "_dot")
        if found is not None and len(found[0]) == len(times):
            return found[1]
        return np.gradient(rate, times)

    p_dot, r_dot = acceleration("p", p), acceleration("r", r)
    # Samples whose central difference spans a control step.
    step = np.zeros(len(times), bool)
    for control in ("aileron", "rudder"):
        jump = np.abs(np.diff(data[control][1])) > np.radians(0.1)
        step[:-1] |= jump
        step[1:] |= jump
    moment_rows = ~step
    q = channel(record, "q")[1] if channel(record, "q") is not None else np.zeros_like(p)
    ixx, iyy, izz, ixz = aircraft["ixx"], aircraft["iyy"], aircraft["izz"], aircraft["ixz"]
    measured = {
        "CY": m * G0 * data["ny"][1] / (qbar * s),
        "Cl": (ixx * p_dot - ixz * (r_dot + p * q) + (izz - iyy) * q * r) / (qbar * s * b),
        "Cn": (izz * r_dot - ixz * (p_dot - q * r) + (iyy - ixx) * p * q) / (qbar * s * b),
    }
    parameters = problem["parameters"]
    results = []
    for coefficient, z in measured.items():
        mine = [q for q in parameters if q["name"].startswith(coefficient + "_")]
        free = [q for q in mine if q["free"]]
        if not free:
            continue
        for q in mine:
            term = q["name"][len(coefficient) + 1:]
            if term not in regressors:
                refuse(work, "unsuitable-model", model=model,
                       reason=f"this example has no regressor for the term '{term}'")
        fixed = [q for q in mine if not q["free"]]
        z = z - sum((q["start"] * regressors[q["name"][len(coefficient) + 1:]] for q in fixed),
                    np.zeros_like(z))
        x = np.column_stack([regressors[q["name"][len(coefficient) + 1:]] for q in free])
        keep = np.all(np.isfinite(x), axis=1) & np.isfinite(z)
        if coefficient != "CY":
            keep &= moment_rows
        x, z = x[keep], z[keep]
        theta, *_ = np.linalg.lstsq(x, z, rcond=None)
        residuals = z - x @ theta
        variance = residuals @ residuals / (len(z) - len(free))
        covariance = variance * np.linalg.inv(x.T @ x)
        for j, q in enumerate(free):
            results.append((q["name"], float(theta[j]), float(np.sqrt(covariance[j, j]))))
    names = {name for name, _, _ in results}
    left = [q["name"] for q in parameters if q["free"] and q["name"] not in names]
    if left:
        refuse(work, "unsuitable-model", model=model,
               reason="this example fits CY, Cl and Cn only; free: " + ", ".join(left))
    estimate = {
        "format": "aeroid-plugin-estimate-1",
        "status": "converged",
        "parameters": [dict(name=n, value=v, standard_error=e) for n, v, e in results],
        "iterations": 1,
        "notes": ["least squares in NumPy " + np.__version__],
    }
    with open(os.path.join(work, "estimate.json"), "w") as f:
        json.dump(estimate, f)


if __name__ == "__main__":
    main(sys.argv[1])
