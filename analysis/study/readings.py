"""Why a claim failed, in one line, where the rule's own reason is not enough.

Each reading says which of three it is: a model difference (Webots against MuJoCo, a
constant the thesis does not give), the thesis' own single run, or the claim does not hold.
Written after the runs, from their evidence; `build` puts it in the `why` column of a claim
or part whose verdict is fails or mixed.
"""

from __future__ import annotations

READINGS = {
    "CR-5a": "a definition the thesis does not give: with an exact evaluation per iteration "
    "policy iteration is the faster; with one evaluation sweep per iteration (19-25 "
    "iterations against 19, beside) value iteration is, as the thesis says",
    "CR-6d": "a model difference: our crawler's moves are deterministic, so 1000 random moves "
    "measure all 80 transitions and the model is complete (the thesis' was not)",
    "CR-11d": "a model difference: Tokic's 6-cycle walks backwards on our crawler (−0.14 m in "
    "100 moves), so its steps are not the larger ones here",
    "CR-13c": "a definition the thesis does not give: measured against the learned table's "
    "optimal values, value iteration's error starts below Q-learning's in 4 of 5 seeds",
    "CR-13a": "constants the thesis does not give (α, λ, how long): at α 0.5 over 5000 moves "
    "not every learner settles into forward walking here",
    "CR-14b": "the thesis' own single runs against five seeds here, at an α it does not give "
    "(0.5; not varied)",
    "CR-15b": "a model difference: another learner's cycle takes the larger steps on our "
    "crawler; the cycle's shape follows the robot's dimensions",
    "CR-13b": "constants the thesis does not give (α 0.5 here, λ, and the values the RMS error "
    "is taken against): Q-learning's error falls more slowly than TD(λ)'s and SARSA(λ)'s here",
    "PB-3": "does not hold on our pole at 0.5 N: with the per-step reward −θ² (PB-2's own "
    "reason) even γ 0.1 balances; the thesis gives neither its pole's constants nor its time "
    "step, and 4 N was not run for this sweep",
    "PB-14b": "the thesis' single run: no seed here has a quiet spell mid-run (the quietest "
    "1000 steps of 8000-16000 are 95-99 % of the median window)",
    "PB-5a": "a model difference: 20 angle bins without the angular velocity never balance our "
    "pole at 0.5 N for 5000 steps (its constants and time step are the project's; 4 N not run)",
    "PB-6b": "a model difference: the approach/away reward (its form is not given) cuts the "
    "falls by a tenth but does not balance 100 angle bins on our pole at 0.5 N",
    "CPG-4": "a model difference, cause open: with the CPG alone the COP of our robot stays "
    "5.1 cm from the stance sole's centre, near the sole's edge (5.25 cm); the thesis gives "
    "no figure for its own",
    "CPG-8": "does not hold for two of three on our robot: the compass amplitude raised to 10° "
    "makes it fall, the hip balancing amplitude raised to 16° lessens the sway; the knee "
    "amplitude lifts the foot higher, as said",
    "NAC-5": "does not hold at α 10, whose learned gaits stand: scaled up to 50 times, the "
    "learned term makes 1 of 5 gaits worse and fall; 3 of 5 do not fall at c = 50, with a COP "
    "reward as good as the CPG alone's or better (cause not examined; the roll joints at "
    "their limits is a guess)",
    "NAC-1": "a model difference or constants the thesis does not give: without the fixes "
    "|θ| stays below 320 at all six sweep points, no higher than with them; our basis holds the "
    "CPG's targets (rad) and phases, and the actor steps only when w is steady (10° over 50 "
    "steps), either of which may keep the inversion tame",
    "CEM-6a": "a model difference, cause open: the means of elites 3 and 4 never fell two "
    "rounds running in our runs, with or without noise",
    "CEM-6b": "a model difference, cause open: elites 3 and 4 fall no more often than 1 and 2 "
    "here (without noise no mean fell at all)",
    "CEM-8a": "a model difference or the thesis' single runs: noise 1.0 did a little better "
    "than 0.8 over five seeds here (the best-trial reading cannot tell them apart)",
    "CEM-9c": "the thesis' single runs (8 against 42 rounds): K 20 reaches K 10's best in fewer "
    "rounds here, but not in fewer K 10 rounds' worth of trials",
    "CEM-10a": "does not hold at equal rounds here: K 100 walks 0.31 m farther than K 50 in 50 "
    "rounds (K 70 does not), though each extra sample gains less (CEM-10b); the thesis' "
    "single runs",
    "CEM-14a": "our runs still improve at round 50 (their bests come at rounds 37-50), so half "
    "of a run's best comes after round 10; the thesis gives no time scale",
    "CEM-20": "does not hold with the lateral penalty: its means never fell in our five runs "
    "(K 20 and K 50 fall occasionally, as the thesis says)",
    "CEM-18a": "a model difference: our robot's optimum raises the ankle-roll amplitude to "
    "17-20° in 8 of 10 seeds; the thesis' one run kept 12",
    "CEM-19a": "a model difference, cause open: no mean of four standing sets fell without "
    "noise in our runs; our trials are deterministic (the thesis' Webots trials were noisy, "
    "its Sec. 6.3), and Σ₀ = I in degrees is an assumption",
    "CEM-22": "a model difference: noise 0.8 lets elite 1 walk about 2 m on our robot, far "
    "beyond elite 2 without noise (the thesis: 0.23 against 0.33 u.d.)",
}


# What a testable claim without a rule yet needs: its evidence is not produced by any
# experiment of the project so far.
NEEDS = {}
