"""A generalisation draw diagnosed again with one more command, or at another step: does
a training command next to the held-out one pin down what the training runs left open;
does a finer step change the verdict?

The draw is read from the committed rows (its effect, seed, floor and commands), so
its truth and the runs of its own commands are the benchmark's (the truth is drawn
from the seed before any command is used, and each trial's seed depends on (seed,
command, trial) only); the extra command adds 3 trials.  With four commands split()
holds out the second, so an extra command above the draw's middle one keeps the
held-out command and trains on its neighbour; the row says whether it stayed
(held_out_as_drawn: split() may also move a quiet held-out command).  Issue 21's draws
1191 (a saturation slip whose held-out response turns between 0.0066 and 0.0070 while
the training runs score 0.0062-0.0105 alike) and 1170 (mu_s fitted where the training
runs score lower than at the truth) are what it was written for.

    python scripts/bench/extra_command.py 1191 50 --out /tmp/extra
    python scripts/bench/extra_command.py 1211 --timestep 5e-5 --out /tmp/step

The second generates the draw's data and diagnoses it at 0.05 ms (issue 18's question:
1211, a null, fails at the default 0.1 ms, whose 30 deg/s on carpet has two regimes).

    python scripts/bench/extra_command.py 1214 --propose first --out /tmp/next
    python scripts/bench/extra_command.py 1178 60 --hold-out-extra --out /tmp/next

takes the extra command from diagnose itself (diagnosis.next_command): the draw's data
diagnosed with its row's two best causes as the only candidates (their fits are the
full diagnosis's: each cause is fitted on its own, and these two are its contenders),
and the swivel that diagnosis proposes to tell them apart (`first`; `last`, the one it
ranks last, is the control: does any extra command do as well?) is added.  The row's
"proposal" holds what the two-cause diagnosis said.  With --hold-out-extra the
extra command is held out (diagnose --hold-out): the fits are trained on the draw's own
commands alone and tested on the recorded proposal, which is what the proposal predicted.
A draw whose held-out command is quiet (the base model within Z_CONSISTENT there) is
diagnosed instead with the one cause its row's training runs ranked first
(fit.training_lead), and the swivel proposed to confirm it is added (the lead is fitted
on its own, every parameter, where the full diagnosis refined only its two best):

    python scripts/bench/extra_command.py 1182 --propose first --hold-out-extra --out /tmp/c

Prints the benchmark's row for the new dataset (bench_diagnose_generalisation.run_case:
everything the verdict rules read) as one JSON line and appends it to OUT/rows.jsonl.
Costs a diagnosis: of 4 commands 1992-2257 s (1170 and 1191 with another job on the
two cores); of 3 at 0.05 ms 2311 s (1213; 796 s at 0.1 ms), 124 s where the base model
already fits (1211, no-discrepancy).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import SimpleNamespace

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_diagnose_generalisation as generalisation  # noqa: E402
from skidsteer.diagnosis import Z_CONSISTENT  # noqa: E402
from skidsteer.diagnosis.fit import training_lead  # noqa: E402

ROWS = Path(__file__).resolve().parents[2] / "docs" / "diagnose-generalisation.jsonl"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int, help="the draw's seed (draw-SEED)")
    ap.add_argument("extra_deg_s", type=float, nargs="?",
                    help="the added command's swivel rate, deg/s (none: the draw's commands)")
    ap.add_argument("--timestep", type=float, help="generate and diagnose at this step, s "
                    "(default: the model's own)")
    ap.add_argument("--results", type=Path, default=ROWS,
                    help="the benchmark rows the draw is read from (default: the committed)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--propose", choices=("first", "last"),
                    help="add the swivel diagnose proposes to tell the row's two best causes "
                         "apart (first) or the one it ranks last (the control)")
    ap.add_argument("--proposal-only", action="store_true",
                    help="with --propose: print what diagnose proposes and stop (no command "
                         "is recorded or diagnosed)")
    ap.add_argument("--hold-out-extra", action="store_true",
                    help="diagnose with the extra command held out (diagnose --hold-out): "
                         "the fits, trained on the draw's own commands, predict it")
    args = ap.parse_args(argv)
    rows = generalisation.newest_rows(args.results)
    if f"draw-{args.seed}" not in rows:
        ap.error(f"no row draw-{args.seed} in {args.results}")
    drawn = generalisation.case_of(rows[f"draw-{args.seed}"])
    if args.proposal_only and not args.propose:
        ap.error("--proposal-only needs --propose")
    if args.propose and args.extra_deg_s is not None:
        ap.error("--propose chooses the extra command: give none")
    proposal = None
    if args.propose:
        proposal = proposed(rows[f"draw-{args.seed}"], drawn, args)
        if not proposal["next_commands"]:
            print(f"draw {args.seed}: diagnose with {' and '.join(proposal['pair'])} proposes "
                  f"no command ({proposal['verdict']}: {proposal['reason']})")
            return 1
        if args.proposal_only:
            print(json.dumps({"case": f"draw-{args.seed}", "proposal": proposal}))
            return 0
        chosen = proposal["next_commands"][0 if args.propose == "first" else -1]
        args.extra_deg_s = chosen["omega_deg_s"]
        print(f"draw {args.seed}: {args.propose} proposal {args.extra_deg_s:g} deg/s "
              f"(separation {chosen['separation']:.2f})")
    if args.extra_deg_s is None and args.timestep is None:
        ap.error("give an extra command, a --timestep, or both")
    if args.hold_out_extra and args.extra_deg_s is None:
        ap.error("--hold-out-extra needs an extra command (or --propose)")
    if args.extra_deg_s in drawn["omegas"]:
        ap.error(f"draw {args.seed} already has {args.extra_deg_s:g} deg/s: {drawn['omegas']}")
    extra = [] if args.extra_deg_s is None else [args.extra_deg_s]
    name = f"draw-{args.seed}" + (f"-plus{args.extra_deg_s:g}" if extra else "")
    if args.timestep is not None:
        name += f"-step{args.timestep:g}"
    case = {**drawn, "case": name, "omegas": sorted([*drawn["omegas"], *extra])}
    row = generalisation.run_case(
        case, args.out, 3, 20.0, args.threads, timestep=args.timestep,
        held_out=[f"v0-w{args.extra_deg_s:g}"] if args.hold_out_extra else None)
    middle = sorted(drawn["omegas"])[1]  # split()'s held-out command with three
    row["held_out_as_drawn"] = any(label.split()[0] == f"v0-w{middle:g}"
                                   for label in row["held_out_groups"])
    if proposal is not None:
        row["proposal"] = {**proposal, "taken": args.propose}
    print(json.dumps(row))
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "rows.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")
    return 0


def proposed(row: dict, drawn: dict, args) -> dict:
    """What diagnose proposes for the draw: its data diagnosed with the row's two best
    causes as the only candidates (the verdict, the reason and next_commands), or, where
    the row's held-out command shows no discrepancy of its own, with the cause the
    training runs ranked first (fit.training_lead of the row's ranking): diagnose then
    proposes the swivel that would confirm it (next_command.CONFIRM)."""
    if row["held_out"][0] <= Z_CONSISTENT:
        fits = [SimpleNamespace(**f) for f in row["ranking"]]
        lead = training_lead(fits, row["base_train"], row["n_train"])
        if lead is None:
            raise SystemExit(f"draw {row['seed']}: its held-out command is quiet and the "
                             "training runs tell no candidate from the base model: nothing "
                             "to confirm")
        pair = [lead.cause]
    else:
        pair = [f["cause"] for f in row["ranking"][:2]]
    generalisation.generate(drawn, args.out, 3, 20.0, args.threads, args.timestep)
    result = generalisation.diagnose(args.out / "datasets" / drawn["case"], None,
                                     candidates=pair, nthread=args.threads, progress=True,
                                     timestep=args.timestep,
                                     cache_dir=args.out / "simulations")
    return {"pair": pair, "verdict": result["verdict"], "reason": result["reason"],
            "next_commands": result["next_commands"], "diagnose_s": result["wall_time_s"]}


if __name__ == "__main__":
    sys.exit(main())
