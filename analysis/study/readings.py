"""Why a claim failed, in one line, where the rule's own reason is not enough.

Each reading says which of three it is: a model difference (Webots against MuJoCo, a
constant the thesis does not give), the thesis' own single run, or the claim does not hold.
Written after the runs, from their evidence; `build` puts it in the `why` column of a claim
or part whose verdict is fails or mixed.
"""

from __future__ import annotations

READINGS = {
    "CR-5a": "a definition: an iteration of policy iteration here evaluates the policy exactly; "
    "the thesis does not say what its Fig. 4.4 counts as one",
    "CR-6d": "a model difference: our crawler's moves are deterministic, so 1000 random moves "
    "measure all 80 transitions and the model is complete (the thesis' was not)",
    "CR-11d": "a model difference: Tokic's 6-cycle walks backwards on our crawler (−0.14 m in "
    "100 moves), so its steps are not the larger ones here",
    "CR-13a": "constants the thesis does not give: TD(0) and SARSA never walk forward at α 0.1, "
    "0.5 or 1 within 1000 moves here",
    "CR-14b": "constants the thesis does not give (α, λ, the run's length) decide the TD "
    "learners' order here",
    "CR-15b": "a model difference: value iteration's cycle takes the larger steps on our "
    "crawler; the cycle's shape follows the robot's dimensions",
    "PB-3": "does not hold on our pole: with the per-step reward −θ² (PB-2's own reason) even "
    "γ 0.1 balances; the thesis gives neither its pole's constants nor its time step",
    "PB-5a": "a model difference: 20 angle bins without the angular velocity never balance our "
    "pole for 5000 steps (its constants and time step are the project's)",
    "PB-6b": "a model difference: the approach/away reward (its form is not given) halves the "
    "falls but does not balance 100 angle bins on our pole",
    "CEM-18a": "a model difference: our robot's optimum raises the ankle-roll amplitude to "
    "about 18° in 9 of 10 seeds; the thesis' one run kept 12",
    "CEM-19a": "a model difference: our trials are deterministic (Webots' were noisy, thesis "
    "Sec. 6.2) and no mean of four standing sets fell without noise",
    "CEM-19b": "a model difference: no mean fell without noise in our runs (see CEM-19a)",
    "CEM-22": "a model difference: noise 0.8 lets elite 1 walk about 2 m on our robot, far "
    "beyond elite 2 without noise (the thesis: 0.23 against 0.33 u.d.)",
    "CPG-5": "does not hold for 2 of the 11 amplitudes: a joint's primitives add with "
    "different phases, so raising one can narrow the joint's swing",
}
