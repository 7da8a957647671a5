"""Train what depends on the hopper for another hopper, and write its hopper folder.

    python3 examples/train_hopper.py --hopper my_hopper.json --out hoppers/mine --jobs 2 --threads 2
    python3 examples/plan_and_hop.py --hopper hoppers/mine --terrain ditch      # the planners read its weights

What holds for any hopper by construction is not retrained: the step-length controller (the flight from apex to
touchdown depends on the hopper only through L0 and g, and the controller works in those units,
``StepLengthController.for_params``), the search planners and the robust presets (every setting in the hopper's
units, drakeslip/units.py), and the footstep models' inputs (lengths in leg lengths, speeds in sqrt(g L0)). What
is retrained is what the hopper's dimensionless stiffness, stroke and friction change, which units cannot scale
away, where no search checks it: the expert-trained footstep model (``lstm_expert.pt``, whose one-step mode is
the ``lstm`` planner's plan) and the re-ranker of its first footholds (``ranker.pt``). The sampled search
(``lstm-guided``) simulates every hop it keeps, so its model only orders the search and is not retrained.

Three steps, each a command of its own, printed before it runs (the same commands run by hand give the same
files), on suites' terrains and starts drawn for the hopper (planners/formats/suite_draw.py):

1. the goal-reaching expert's rollouts for the hopper (examples/generate_dataset.py --planner expert --hopper);
2. the committed expert model fine-tuned on them (examples/train_lstm.py --init planners/weights/lstm_expert.pt);
3. the re-ranker trained in DAgger rounds on the fine-tuned model's states (examples/train_ranker.py --hopper).

OUT becomes a hopper folder: OUT/hopper.json, OUT/lstm_expert.pt, OUT/ranker.pt and the SHA256SUMS manifest
(drakeslip/hopper_file.py); ``--hopper OUT`` on any script then plans with the folder's weights instead of the
committed ones, each checked against the manifest. OUT/training/ holds each step's data and state:
OUT/training/STEP.done marks a finished step, and rerunning the same command skips finished steps and resumes
the others (a dataset's missing shards, the training's remaining epochs, the ranker's missing rounds);
OUT/training/config.json records the settings, and other settings are refused. Weights are written atomically,
the folder's files last. Every size is a flag; the defaults are sized for a few minutes on 2 cores (--jobs 2
--threads 2), each step showing its progress.

Exit status: 0 when the folder was written, 1 when a step failed (its own exit status is printed), 2 for a usage
error (reported before any work).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip.devices import DEVICE_HELP, torch_device
from drakeslip.jobs.files import MANIFEST, atomic_write, read_json, record_digest
from drakeslip.jobs.steps import end_by_sigint, run_step, shown
from planners.checkpoints import EXPERT_WEIGHTS, RANKER_WEIGHTS

# the expert's dataset and training settings (examples/train_expert.py), the hopper's friction instead of 0.8
EXPERT_DATA = ["--planner", "expert", "--subcells", "4", "--min-steps", "1", "--start-x", "-1", "--heights",
               "0.55,1.1", "--speeds", "0.4,3.2", "--explore", "0.3"]
SOFT_LABELS = ["--own-inputs", "0", "--viable-weight", "0.5"]
STEPS = ("expert-data", "expert-model", "ranker")
# what the training folder's data and models depend on (--jobs, --threads, --device may vary)
SETTINGS = ("terrains", "apexes", "epochs", "lr", "ranker_rounds", "ranker_terrains", "ranker_epochs", "seed")


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--hopper", type=hopper_file, required=True, help="the hopper file (JSON or TOML)")
    ap.add_argument("--out", type=cli.output_folder, required=True, help="the hopper folder to write")
    ap.add_argument("--terrains", type=cli.positive_int, default=48, help="terrains of the expert's rollouts")
    ap.add_argument("--apexes", type=cli.positive_int, default=8, help="initial states per terrain")
    ap.add_argument("--epochs", type=cli.positive_int, default=2, help="fine-tuning epochs of the expert model")
    ap.add_argument("--lr", type=cli.positive, default=1e-3, help="peak learning rate of the fine-tuning")
    ap.add_argument("--ranker-rounds", type=cli.positive_int, default=2, help="DAgger rounds of the re-ranker")
    ap.add_argument("--ranker-terrains", type=cli.integer(1, 1000), default=12,
                    help="terrains per family and round of the re-ranker's data")
    ap.add_argument("--ranker-epochs", type=cli.positive_int, default=30, help="re-ranker training epochs per round")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the terrains and initial states")
    ap.add_argument("--threads", type=cli.non_negative_int, default=0,
                    help="torch CPU threads for training (0: torch's default)")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--quiet", action="store_true", help="no progress bars or per-epoch lines from the steps")
    ap.add_argument("--dry-run", action="store_true", help="print the steps' commands and exit, running nothing")
    cli.add_parallel(ap)
    return ap


def hopper_file(text: str):
    """An argument type: a hopper file (not a folder: this command writes the folder), read up front."""
    import argparse

    from drakeslip.hopper_file import hopper_argument

    hopper = hopper_argument(text)
    if hopper.folder is not None:
        raise argparse.ArgumentTypeError(f"{text!r} is a hopper folder; give its hopper file "
                                         f"({hopper.source}) and a new --out")
    return hopper


def step_commands(args, device: str) -> dict[str, list[str]]:
    """The command of each step (see the module doc), reading the hopper from OUT/hopper.json."""
    work, hopper = args.out / "training", str(args.out / "hopper.json")
    parallel = ["--jobs", str(args.jobs)] + (["--executor", "ray"] if args.executor == "ray" else []) + \
        (["--address", args.address] if args.address else [])
    quiet = ["--quiet"] if args.quiet else []
    return {
        "expert-data": ["generate_dataset.py", *EXPERT_DATA, "--hopper", hopper, "--terrains", str(args.terrains),
                        "--apexes", str(args.apexes), "--seed", str(args.seed), "--out", str(work / "expert-data"),
                        *parallel, *quiet],
        "expert-model": ["train_lstm.py", "--data", str(work / "expert-data"), "--init", str(EXPERT_WEIGHTS),
                         "--out", str(work / EXPERT_WEIGHTS.name), "--checkpoint", str(work / "expert-checkpoint.pt"),
                         "--epochs", str(args.epochs), "--lr", str(args.lr), *SOFT_LABELS, "--seed", str(args.seed),
                         "--threads", str(args.threads), "--device", device, *quiet],
        "ranker": ["train_ranker.py", "--hopper", hopper, "--model", str(work / EXPERT_WEIGHTS.name),
                   "--rounds", str(args.ranker_rounds), "--terrains", str(args.ranker_terrains),
                   "--shard-terrains", str(max(1, -(-args.ranker_terrains // 2))), "--epochs", str(args.ranker_epochs),
                   "--seed", str(100000 + args.seed), "--data-dir", str(work / "ranker"),
                   "--out", str(work / RANKER_WEIGHTS.name), "--threads", str(args.threads), "--device", device,
                   *parallel, *quiet],
    }


def check_settings(work: Path, settings: dict) -> None:
    """Record ``settings`` in WORK/config.json, or, resuming, refuse others than those recorded (ValueError)."""
    settings = json.loads(json.dumps(settings))
    path = work / "config.json"
    if path.exists():
        recorded = read_json(path, "train_hopper config")
        changed = [k for k in sorted(set(settings) | set(recorded if isinstance(recorded, dict) else {}))
                   if not isinstance(recorded, dict) or settings.get(k) != recorded.get(k)]
        if changed:
            raise ValueError(f"{work} was made with other settings ({', '.join(changed)} differ, see {path}); "
                             "use another --out")
        return
    work.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w") as f:
        json.dump(settings, f, indent=1)


def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    try:
        device = torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")
    if args.executor == "local" and args.address is not None:
        ap.error("--address is for --executor ray")
    from drakeslip.hopper_file import FOLDER_FILE

    ap.check_outputs(args, [("--out", args.out / name) for name in (FOLDER_FILE, MANIFEST, EXPERT_WEIGHTS.name,
                                                                    RANKER_WEIGHTS.name)])
    commands = step_commands(args, device)
    if args.dry_run:
        print("\n".join(shown(command) for command in commands.values()))
        return cli.OK

    from drakeslip.hopper_file import hopper_document, make_hopper_folder

    work = args.out / "training"
    try:
        check_settings(work, {"hopper": hopper_document(args.hopper), **{k: getattr(args, k) for k in SETTINGS}})
        make_hopper_folder(args.hopper, args.out)
    except (ValueError, OSError) as error:
        ap.error(str(error))
    cli.announce(argv)
    t0 = time.perf_counter()
    try:
        for k, (step, command) in enumerate(commands.items(), 1):
            done = work / f"{step}.done"
            if done.exists():
                print(f"step {k}/{len(STEPS)} {step}: done", flush=True)
                continue
            print(f"step {k}/{len(STEPS)} {step} ({time.perf_counter() - t0:.0f} s so far)", flush=True)
            code = run_step(command, Path(__file__).resolve().parent)
            if code != cli.OK:
                print(f"{ap.prog}: step {step} failed: {command[0]} exited with status {code}; rerun to resume",
                      file=sys.stderr)
                return cli.FAILED
            with atomic_write(done, "w") as f:
                f.write(f"{step} finished\n")
    except KeyboardInterrupt:  # between two steps (during one, the step says what it saved)
        print(f"{ap.prog}: interrupted: the finished steps are kept in {work}; rerun the same command to resume",
              file=sys.stderr)
        end_by_sigint()
    for weights in (EXPERT_WEIGHTS.name, RANKER_WEIGHTS.name):
        with atomic_write(args.out / weights) as f:
            f.write((work / weights).read_bytes())
        record_digest(args.out / weights)
    print(f"wrote the hopper folder {args.out} ({time.perf_counter() - t0:.0f} s): hopper.json, "
          f"{EXPERT_WEIGHTS.name}, {RANKER_WEIGHTS.name}, SHA256SUMS; use it with --hopper {args.out}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
