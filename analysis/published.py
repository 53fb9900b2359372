"""Published numbers of the study, with their sources (THESIS.md Sec. 6 ids).

Distances are the thesis' "u.d." (units of distance, never defined; Webots' default unit is
the metre). Only the CEM results of thesis Table 6.3 and Sec. 6.3 are here so far.
"""

from __future__ import annotations

# Thesis Table 6.3 and Sec. 6.3: setting -> (best distance, round of best, id of distance,
# id of round). Setting names match `baselines.cem.TABLE6_3`.
TABLE6_3 = {
    "K10_n0_e1": (0.068321, 2, "CEM-N06", "CEM-N07"),
    "K10_n0_e2": (0.328687, 6, "CEM-N08", "CEM-N09"),
    "K10_n0_e3": (0.161517, 11, "CEM-N10", "CEM-N11"),
    "K10_n0_e4": (0.072173, 3, "CEM-N12", "CEM-N13"),
    "K10_n0.8_e1": (0.234469, 7, "CEM-N14", "CEM-N15"),
    "K10_n0.8_e2": (0.549083, 42, "CEM-N16", "CEM-N17"),
    "K10_n0.8_e3": (0.390968, 23, "CEM-N18", "CEM-N19"),
    "K10_n0.8_e4": (0.235189, 6, "CEM-N20", "CEM-N21"),
    "K20_n0.8_e2": (1.019418, 40, "CEM-N22", "CEM-N23"),
    "K50_n0.8_e2": (1.782815, 42, "CEM-N25", "CEM-N26"),
    "K10_n0.8_e2_lateral": (0.47, 58, "CEM-N30", "CEM-N31"),
}

# Sec. 6.3 statements without a number: noise 0.2 and 1.0 do worse than 0.8 (K 10, elite 2).
NOISE_CLAIMS = {
    "K10_n0.2_e2": "below noise 0.8 and slower (CEM-N33)",
    "K10_n1_e2": "worse than noise 0.8 (CEM-N32)",
}

SOURCE = "Duarte, thesis Table 6.3 and Sec. 6.3"
