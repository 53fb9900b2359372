"""Published numbers and claims of the study, with their sources.

* `published.csv`: every number and claim row we took from the thesis
  (docs/study.md#ids-of-published-numbers-and-claims; ids like `CEM-N25`): domain, method,
  setting, quantity, value, unit, thesis section/table/figure, kind (number / claim).
* `published_claims.csv`: every testable claim of the thesis' text (ids like `CR-1`,
  `PB-8`, `NAC-3`), with its statement.

Both were extracted from Duarte's thesis ("Using Reinforcement Learning in the
tuning of Central Pattern Generators", U. Minho); distances are its "u.d." (units of
distance, never defined; Webots' default unit is the metre).
"""

from __future__ import annotations

import csv
import importlib.resources


def _read(name: str) -> list[dict]:
    text = importlib.resources.files("analysis").joinpath(name).read_text(encoding="utf-8")
    return list(csv.DictReader(text.splitlines()))


# Every number and claim row the study publishes, by id (docs/study.md).
NUMBERS = {row["id"]: row for row in _read("published.csv")}
# Every narrative claim (CR-n, PB-n, CPG-n, NAC-n, CEMT-n), id -> statement.
CLAIMS = {row["id"]: row["statement"] for row in _read("published_claims.csv")}
for _id, _row in NUMBERS.items():
    if _row["kind"] == "claim":
        CLAIMS[_id] = (
            f"{_row['domain']} / {_row['method']} / {_row['setting']}: "
            f"{_row['quantity']} = {_row['value']} ({_row['source']})"
        )

# Thesis Table 6.3 and Sec. 6.3: setting -> (best distance, round of best, id of distance,
# id of round). Setting names match `baselines.cem.TABLE6_3`.
_TABLE6_3_IDS = {
    "K10_n0_e1": ("CEM-N06", "CEM-N07"),
    "K10_n0_e2": ("CEM-N08", "CEM-N09"),
    "K10_n0_e3": ("CEM-N10", "CEM-N11"),
    "K10_n0_e4": ("CEM-N12", "CEM-N13"),
    "K10_n0.8_e1": ("CEM-N14", "CEM-N15"),
    "K10_n0.8_e2": ("CEM-N16", "CEM-N17"),
    "K10_n0.8_e3": ("CEM-N18", "CEM-N19"),
    "K10_n0.8_e4": ("CEM-N20", "CEM-N21"),
    "K20_n0.8_e2": ("CEM-N22", "CEM-N23"),
    "K50_n0.8_e2": ("CEM-N25", "CEM-N26"),
    "K10_n0.8_e2_lateral": ("CEM-N30", "CEM-N31"),
}
# The values come from published.csv, the one place the study's numbers are typed.
TABLE6_3 = {
    setting: (float(NUMBERS[d]["value"]), int(NUMBERS[r]["value"]), d, r)
    for setting, (d, r) in _TABLE6_3_IDS.items()
}

# Sec. 6.3 statements without a number: noise 0.2 and 1.0 do worse than 0.8 (K 10, elite 2).
NOISE_CLAIMS = {
    "K10_n0.2_e2": "below noise 0.8 and slower (CEM-N33)",
    "K10_n1_e2": "worse than noise 0.8 (CEM-N32)",
}

SOURCE = "Duarte, thesis Table 6.3 and Sec. 6.3"

# Real-time crawler displacements (thesis Sec. 4.1.7): method -> (u.d., source).
CRAWLER = {
    method: (float(NUMBERS[i]["value"]), f"thesis 4.1.7 ({i}; u.d., Webots crawler)")
    for method, i in (("value_iteration", "CR-N21"), ("td0", "CR-N23"), ("td_lambda", "CR-N24"))
}
