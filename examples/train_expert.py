"""Train the expert-trained footstep model (the committed planners/weights/lstm_expert.pt) from nothing: the
goal-reaching expert's rollouts, then DAgger rounds.

    python3 examples/train_expert.py --work data/expert --out planners/weights/lstm_expert.pt --jobs 2 --threads 2

Round 0 generates the expert's rollouts (examples/generate_dataset.py --planner expert) from the first of
--terrains terrains and trains a fresh model on them (examples/train_lstm.py, --hidden x --channels, the first of
--epochs). Round r > 0 is a DAgger round: the rollouts follow the one-step mode planner of round r-1's model
where it stays goal-reaching (--policy), on the r-th of --terrains terrains with terrain seed --seed + r, and
round r-1's model is fine-tuned on every round's data so far (--init). Every round's dataset has the expert's
settings (2.5 cm bins, --min-steps 1, starts from x = -1 m, apex heights 0.55-1.1 m and speeds 0.4-3.2 m/s,
friction 0.8) and its training the soft labels (--viable-weight 0.5, --own-inputs 0). The last round's model is
copied to --out, and the SHA256SUMS manifest of --out's folder, if it has one, gets the file's new digest.
--hopper trains the model for another hopper than the paper's: every round's data are its own (generate_dataset.py
--hopper, on its friction); examples/train_hopper.py fine-tunes the committed model for one in a few minutes.

Each step is a command of its own, printed before it runs (run by hand, the same commands give the same files).
WORK/round{r}/ holds round r's dataset, WORK/round{r}.pt its model and WORK/round{r}-checkpoint.pt its training
state; WORK/round{r}.done marks a finished round. Rerunning the same command skips finished rounds and resumes
the others (the dataset's missing shards, the training's remaining epochs); WORK/config.json records the settings,
and other settings are refused. Every size is a flag, every random choice seeded: the same command gives the same
datasets and, on the same device, the same model.

Exit status: 0 when the model was written, 1 when a step failed (its own exit status is printed), 2 for a usage
error (reported before any work).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.devices import DEVICE_HELP, torch_device
from drakeslip.jobs.files import atomic_write, read_json, record_digest
from drakeslip.jobs.steps import end_by_sigint, run_step, shown
from planners.checkpoints import EXPERT_WEIGHTS

# the expert's dataset settings, the same in every round (see the module doc)
EXPERT_DATA = ["--planner", "expert", "--subcells", "4", "--min-steps", "1", "--start-x", "-1", "--heights",
               "0.55,1.1", "--speeds", "0.4,3.2", "--friction", "0.8"]
SOFT_LABELS = ["--own-inputs", "0", "--viable-weight", "0.5"]
# what a work folder's datasets and models depend on (--jobs, --threads, --device and --out may vary)
SETTINGS = ("terrains", "epochs", "apexes", "seed", "explore", "lr", "hidden", "channels")


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--out", type=cli.output_file(".pt"), default=EXPERT_WEIGHTS,
                    help="the last round's model is copied here")
    ap.add_argument("--work", type=cli.output_folder, default="data/expert",
                    help="each round's dataset, model and training state")
    counts = cli.numbers(None, cli.positive_int)
    ap.add_argument("--terrains", type=counts, default="184,500,250",
                    help="terrains of each round's dataset, comma-separated: round 0 (the expert's rollouts), then "
                         "one per DAgger round")
    ap.add_argument("--epochs", type=counts, default="52,12,10",
                    help="training epochs of each round, as many as --terrains")
    ap.add_argument("--apexes", type=cli.positive_int, default=8, help="initial states per terrain")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0,
                    help="round r's terrains and initial states are drawn with seed SEED + r")
    ap.add_argument("--explore", type=cli.probability, nargs=2, default=(0.3, 0.1), metavar=("ROUND0", "LATER"),
                    help="chance a rollout hops to a random goal-reaching foothold, in round 0 and in DAgger rounds")
    ap.add_argument("--lr", type=cli.positive, nargs=2, default=(2e-3, 1e-3), metavar=("ROUND0", "LATER"),
                    help="peak learning rate of round 0 (a fresh model) and of the DAgger rounds (fine-tuning)")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--hidden", type=cli.positive_int, default=256, help="LSTM units per layer")
    ap.add_argument("--channels", type=cli.positive_int, default=32, help="CNN feature maps")
    ap.add_argument("--threads", type=cli.non_negative_int, default=0,
                    help="torch CPU threads for training (0: torch's default)")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--quiet", action="store_true", help="no progress bars or per-epoch lines from the steps")
    ap.add_argument("--dry-run", action="store_true", help="print every round's commands and exit, running nothing")
    cli.add_parallel(ap)
    return ap


def check_settings(work: Path, settings: dict) -> None:
    """Record ``settings`` in WORK/config.json, or, resuming, refuse others than those recorded (ValueError)."""
    settings = json.loads(json.dumps(settings))  # tuples as lists, as read back
    path = work / "config.json"
    if path.exists():
        recorded = read_json(path, "train_expert config")
        if not isinstance(recorded, dict):
            raise ValueError(f"train_expert config {path} is not a JSON object")
        changed = [k for k in sorted(set(settings) | set(recorded)) if settings.get(k) != recorded.get(k)]
        if changed:
            raise ValueError(f"{work} was made with other settings ({', '.join(changed)} differ, see {path}); "
                             "use another --work")
        return
    with atomic_write(path, "w") as f:
        json.dump(settings, f, indent=1)


def round_commands(args, r: int, device: str) -> list[list[str]]:
    """The two commands of round r: its dataset, then its training."""
    work = Path(args.work)
    data = ["--jobs", str(args.jobs)] + (["--executor", "ray"] if args.executor == "ray" else []) + \
        (["--address", args.address] if args.address else [])
    explore = args.explore[0] if r == 0 else args.explore[1]
    data += [] if args.hopper is None else ["--hopper", str(args.hopper.source), "--friction",
                                            repr(args.hopper.params.friction)]
    generate = ["generate_dataset.py", *EXPERT_DATA, "--terrains", str(args.terrains[r]), "--apexes", str(args.apexes),
                "--explore", str(explore), "--seed", str(args.seed + r), "--out", str(work / f"round{r}"), *data]
    if r > 0:
        generate += ["--policy", str(work / f"round{r - 1}.pt")]
    train = ["train_lstm.py", "--data", ",".join(str(work / f"round{k}") for k in range(r + 1)),
             "--out", str(work / f"round{r}.pt"), "--checkpoint", str(work / f"round{r}-checkpoint.pt"),
             "--epochs", str(args.epochs[r]), "--lr", str(args.lr[0] if r == 0 else args.lr[1]), *SOFT_LABELS,
             "--threads", str(args.threads), "--device", device]
    train += ["--hidden", str(args.hidden), "--channels", str(args.channels)] if r == 0 else \
        ["--init", str(work / f"round{r - 1}.pt")]
    quiet = ["--quiet"] if args.quiet else []
    return [generate + quiet, train + quiet]


def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    if len(args.epochs) != len(args.terrains):
        ap.error(f"--epochs has {len(args.epochs)} entries and --terrains {len(args.terrains)}: give one per round")
    try:
        device = torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")
    if args.executor == "local" and args.address is not None:
        ap.error("--address is for --executor ray")
    work = Path(args.work)
    if args.dry_run:
        for r in range(len(args.terrains)):
            print("\n".join(shown(command) for command in round_commands(args, r, device)))
        return cli.OK
    try:
        settings = {k: getattr(args, k) for k in SETTINGS}
        if args.hopper is not None:   # the paper's work folders keep their settings as they were
            settings["hopper"] = {"name": args.hopper.name, "sha256": args.hopper.sha256}
        check_settings(work, settings)
    except (ValueError, OSError) as error:
        ap.error(str(error))
    cli.announce(argv)
    rounds, t0 = len(args.terrains), time.perf_counter()
    try:
        for r in range(rounds):
            model, done = work / f"round{r}.pt", work / f"round{r}.done"
            if done.exists() and model.exists():
                print(f"round {r} ({rounds} in all): done ({model})", flush=True)
                continue
            print(f"round {r} ({rounds} in all): " + ("the expert's rollouts" if r == 0 else "DAgger"), flush=True)
            for command in round_commands(args, r, device):
                code = run_step(command, Path(__file__).resolve().parent)
                if code != cli.OK:
                    print(f"{ap.prog}: round {r} failed: {command[0]} exited with status {code}; rerun to resume",
                          file=sys.stderr)
                    return cli.FAILED
            with atomic_write(done, "w") as f:
                f.write(f"round {r} finished\n")
    except KeyboardInterrupt:  # between two steps (during one, the step says what it saved)
        print(f"{ap.prog}: interrupted: the finished rounds are kept in {work}; rerun the same command to resume",
              file=sys.stderr)
        end_by_sigint()
    with atomic_write(args.out) as f:
        f.write((work / f"round{rounds - 1}.pt").read_bytes())
    record_digest(args.out)
    print(f"wrote {args.out} ({time.perf_counter() - t0:.0f} s)")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
