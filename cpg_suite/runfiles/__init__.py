"""The run folder's files: how runs are written and read, by training and by the protocol.

* `runs`: run directories (`<output_dir>/<method>/<task>/<run_name>/`), atomic writes,
  JSON and CSV files, the progress file, `config.json` (settings, command line, versions).
* `exported`: policies as data, `selected_policy.npz` (an MLP run with NumPy) and
  `selected_actions.npy` (an open-loop table of actions).
* `sb3_policy`: a Stable-Baselines3 policy from its pickles (`selected_model.zip`,
  `selected_vecnormalize.pkl`); needs the `rl` extra.

Both the harness (`cpg_suite.harness`, which writes runs) and the protocol
(`cpg_suite.protocol`, which scores, submits and verifies them) import these modules; they
import neither (tests/test_layout.py).
"""
