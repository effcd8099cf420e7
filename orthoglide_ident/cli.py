"""``orthoglide-ident``: offline identification, bag info, base model and reports
(docs/design/interfaces.md).

    orthoglide-ident identify [--robot FILE] BAG... [--payload-mass KG] [--method tls|wls]
                     [--payload-known mass|com|all|point]
                     [--gains G1,G2,...|FILE.json] [--essential] [--json FILE]
                     [--r-sigma R] [--config YAML] [--validate BAG...]
                     [--consistent] [--urdf-out FILE]
    orthoglide-ident info BAG...
    orthoglide-ident reindex BAG...
    orthoglide-ident model [--robot FILE] --base-parameters [--json FILE]
    orthoglide-ident report [--robot FILE] BAG... --out DIR [--mcap FILE] [identify options]
    orthoglide-ident import CSV... --out BAG [--map YAML] [column flags]   (import_command.py)
    orthoglide-ident excite design|check --robot FILE ...   (exciting trajectories: excite/cli.py)

``--robot``: a URDF, a robot YAML or a bundled robot's name (model/registry.py); without it, the
Orthoglide exactly as before.
    orthoglide-ident identify --service [BAG...] [--method tls|wls] [--essential] [--json FILE]
                     [--payload-mass KG]                                         (ROS 2)
    orthoglide-ident record start|stop|status [--condition C --payload-mass KG --name N]  (ROS 2)
    orthoglide-ident watch [--seconds S]                                          (ROS 2)

Exit codes: 0 success; 2 bad input (a one-line reason on stderr, never a traceback);
1 internal error (a bug: set ORTHOGLIDE_DEBUG=1 for the traceback); 130 interrupted;
141 standard output closed early (``| head``; quietly, as a process ended by SIGPIPE).
Progress of long steps goes to stderr; results go to stdout.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path

from orthoglide_ident import import_command, ros_client
from orthoglide_ident.errors import ConfigError, IdentificationError, OrthoglideError
from orthoglide_ident.flags import prepare_outputs
from orthoglide_ident.identify.solve.methods import CROSS_CHECKS, DEFAULT_METHOD, METHODS
from orthoglide_ident.model.registry import (
    add_description_options,
    bundled_robots,
    load_robot_from_args,
)
from orthoglide_ident.progress import StageAwareHandler, Stages, set_quiet, shown

PROG = "orthoglide-ident"
EXIT_OK, EXIT_BUG, EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_BROKEN_PIPE = 0, 1, 2, 130, 141


def parse_gains(text: str, joints: Sequence[str]) -> list[float]:
    """One drive gain per joint of ``joints`` (N/A or N·m/A) from ``G1,G2,...`` or a JSON file (an
    ``identify --json`` result, a list of numbers, or a mapping joint name -> gain)."""
    p = Path(text)
    if "," not in text or p.exists():
        try:
            doc = json.loads(p.read_text())
        except OSError as exc:
            raise ConfigError(f"--gains {text}: neither G1,G2,G3 nor a readable JSON file "
                              f"({exc.strerror or exc})") from None
        except json.JSONDecodeError as exc:
            raise ConfigError(f"--gains {text}: not valid JSON ({exc.msg} at line "
                              f"{exc.lineno})") from None
        if isinstance(doc, dict) and "drive_gains" in doc:
            doc = doc["drive_gains"]
        if isinstance(doc, dict):
            try:
                doc = [doc[j] for j in joints]
            except KeyError as exc:
                raise ConfigError(f"--gains {text}: no gain for joint {exc.args[0]}") from None
        if isinstance(doc, list):
            vals = [d.get("value") if isinstance(d, dict) else d for d in doc]
        else:
            raise ConfigError(f"--gains {text}: expected drive_gains, a list or a joint mapping")
    else:
        vals = text.split(",")
    try:
        gains = [float(v) for v in vals]
    except (TypeError, ValueError):
        raise ConfigError(f"--gains {text}: drive gains must be numbers") from None
    if len(gains) != len(joints) or not all(math.isfinite(g) and g > 0 for g in gains):
        raise ConfigError(f"--gains {text}: give {len(joints)} positive drive gains "
                          f"({','.join(joints)})")
    return gains


def _add_robot_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--robot",
        metavar="FILE",
        default="",
        help="the robot: a URDF, a .urdf.xacro, an MJCF .xml, a robot YAML "
        f"(docs/guide/robot_files.md) or a bundled robot ({', '.join(bundled_robots())})"
        "; default the Orthoglide (the paper's closed form)",
    )
    add_description_options(p)


def _add_identify_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("bags", nargs="*", metavar="BAG",
                   help="rosbag2 directories or lone .mcap files, tagged loaded|unloaded")
    p.add_argument("--payload-mass", type=float, metavar="KG",
                   help="weighed payload mass of the loaded bags in kg (checked against their tags;"
                        " needed when a loaded bag carries no mass)")
    p.add_argument("--payload-known", choices=("mass", "com", "all", "point"), default=None,
                   help="what is known of the loaded bags' payload (paper Sect. 4.3; default: "
                        "each bag's tag, orthoglide.payload_known, else what it gives): mass "
                        "(weighed; its CoM and inertia are identified with the robot), com (mass "
                        "and CoM; inertia identified), all (mass, CoM and inertia from the tag), "
                        "point (a point mass at the payload frame, or at the tagged CoM)")
    p.add_argument("--method", choices=tuple(METHODS), default=None,
                   help="; ".join(f"{m.name}: {m.help}" + (" (default)" if m.name == DEFAULT_METHOD
                                                           else "") for m in METHODS.values()))
    p.add_argument("--gains", metavar="G1,G2,...|FILE.json",
                   help="drive gains (N/A, N·m/A for a revolute joint) for --method wls: one per "
                        "joint, or a JSON file (e.g. the --json output of a TLS identification)")
    p.add_argument("--cross-check", choices=CROSS_CHECKS + ("none",), default=None,
                   help="after --method tls, IDIM-IV from its answer: a gain further than 3 "
                        "combined σ from IV's is not determined, with the reason (default iv)")
    p.add_argument("--essential", action="store_true",
                   help="also reduce to essential parameters (paper Sect. 5.2) and show base and "
                        "essential results side by side")
    p.add_argument("--r-sigma", type=float, metavar="R",
                   help="stop ratio max %%σ / min %%σ of the essential reduction (default 10)")
    p.add_argument("--config", metavar="YAML",
                   help="options file (config/identification.yaml format: cut-offs in Hz and "
                        "lengths in s, 0 = from the record's rate; velocity_source, velocity dead "
                        "band in m/s, excitation limits...)")
    p.add_argument("--validate", nargs="+", default=[], metavar="BAG",
                   help="bags not used for identification, to cross-validate the model on")
    p.add_argument("--consistent", action="store_true",
                   help="physically consistent standard parameters (every body's pseudo-inertia "
                        "positive semidefinite, ia, fv, fs >= 0): the answer projected onto them "
                        "and the standard parameters identified under these constraints with the "
                        "gains held, side by side; with --validate, the consistent model is also "
                        "forward-simulated under the recorded currents")
    p.add_argument("--urdf-out", metavar="FILE",
                   help="write the identified model as a URDF (consistent inertials, friction "
                        "in <dynamics>, rotor inertia and gains in comments) that Pinocchio and "
                        "MuJoCo load; implies --consistent")
    p.add_argument("--mjcf-out", metavar="FILE",
                   help="write the identified robot as an MJCF for MuJoCo (consistent inertials; "
                        "joint armature = rotor inertia, damping = viscous, frictionloss = "
                        "Coulomb friction; a motor actuator per actuator, control in A, gear = "
                        "drive gain); implies --consistent")
    p.add_argument(
        "--json",
        metavar="FILE",
        help="write the result as JSON (docs/design/interfaces.md) to FILE "
        "(strict JSON: a number that is missing is null; drive_gains[i].determined, "
        "reason)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    _add_robot_option(p)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Identification of a robot's drive gains and dynamic parameters together "
                    "(IDIM-TLS, Briot & Gautier 2013) from tagged rosbag2/MCAP bags: the "
                    "Orthoglide by default, any robot with --robot (a URDF or robot YAML). "
                    "Units: m or rad, A, N or N·m, kg, N/A or N·m/A.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    p = sub.add_parser("identify", help="identify gains and base parameters from bags",
                       description="Identify drive gains (N/A) and base dynamic parameters from "
                                   "unloaded and loaded bags; prints a table, --json writes JSON. "
                                   "When the data fix only some gains (a joint that hardly moved, "
                                   "a payload that adds no torque on an axis) the others are "
                                   "given with their σ and those marked 'not determined' with "
                                   "the reason and what to record (exit 0; option "
                                   "partial_answers: false for all or nothing).")
    _add_identify_options(p)
    p.add_argument("--service", action="store_true",
                   help="ask the identification node instead (ROS 2 service orthoglide/identify): "
                        "with no BAG, the live data of the recordings; the result is latched for "
                        "the ctc node")
    ros_client.add_namespace(p)
    p = sub.add_parser("info", help="print what a bag holds (topics, counts, gaps, tag)",
                       description="Print topics, message counts, rate, gaps and the "
                                   "loaded/unloaded tag of each bag.")
    p.add_argument("bags", nargs="+", metavar="BAG")
    p = sub.add_parser("reindex", help="repair a bag whose recorder was killed",
                       description="Write a closed copy of every .mcap file that was cut short "
                                   "(every complete chunk; the original is kept as "
                                   "<file>.mcap.orig) and rebuild metadata.yaml from the files: "
                                   "message counts, start and duration, topics with their QoS, "
                                   "custom_data tags. Says what was lost.")
    p.add_argument("bags", nargs="+", metavar="BAG",
                   help="rosbag2 directories or lone .mcap files")
    p = sub.add_parser("model", help="print the base parameters of the robot's model",
                       description="Print the base parameters (name, legs, regrouping expression "
                                   "of standard parameters) of the Orthoglide or --robot.")
    _add_robot_option(p)
    p.add_argument("--base-parameters", action="store_true",
                   help="the base-parameter table (the default and only listing)")
    p.add_argument("--json", metavar="FILE", help="also write the base model as JSON to FILE")
    p = sub.add_parser("report", help="identify and write plots and a Markdown summary",
                       description="Identify as `identify` does, then write torques.png "
                                   "(measured vs model forces, paper Fig. 5), parameters.png "
                                   "(%%σ), summary.md and result.json into --out.")
    _add_identify_options(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument(
        "--mcap",
        metavar="FILE",
        help="also write the plots as an MCAP file for Foxglove or "
        "Lichtblick (forces, residual, the gains' convergence; "
        "orthoglide_ident/view/report_mcap.py)",
    )
    import_command.add_parser(sub)
    ros_client.add_parsers(sub)
    from orthoglide_ident.excite.cli import add_excite_commands
    from orthoglide_ident.excite.run_command import add_run_command

    add_run_command(add_excite_commands(sub))  # design, check (ACTIONS), and run on the robot
    return parser


def _setup_logging(quiet: bool) -> None:
    log = logging.getLogger("orthoglide_ident")
    log.handlers[:] = []
    h = StageAwareHandler(sys.stderr)  # a log line erases the progress line first
    h.setFormatter(logging.Formatter(f"{PROG}: %(message)s"))
    log.addHandler(h)
    log.setLevel(logging.WARNING if quiet else logging.INFO)
    log.propagate = False
    set_quiet(quiet)  # and no progress line (progress.py)


def _run_identify(args: argparse.Namespace):
    from orthoglide_ident.identify.options import IdentifyOptions
    from orthoglide_ident.identify.pipeline import identify
    robot = load_robot_from_args(args)
    opts = IdentifyOptions.from_yaml(args.config) if args.config else IdentifyOptions()
    if args.r_sigma is not None:
        if not args.r_sigma > 1:
            raise ConfigError(f"--r-sigma must be > 1 (the paper uses 10), not {args.r_sigma}")
        opts = opts.replace(r_sigma=args.r_sigma)
    if args.consistent or args.urdf_out or args.mjcf_out:
        if args.mjcf_out and not args.consistent:
            logging.getLogger("orthoglide_ident").info(
                "--mjcf-out: running the consistency step (MuJoCo needs physically consistent "
                "inertials)")
        opts = opts.replace(consistent=True)
    if getattr(args, "payload_known", None):
        opts = opts.replace(payload_known=args.payload_known)
    if getattr(args, "cross_check", None):
        opts = opts.replace(cross_check=args.cross_check)
    method = args.method or DEFAULT_METHOD
    gains = parse_gains(args.gains, robot.joint_names) if args.gains else None
    if gains is not None and not METHODS[method].gains_given:
        given = " or ".join(m.name for m in METHODS.values() if m.gains_given)
        raise ConfigError(f"--gains is for --method {given}: IDIM-{method.upper()} identifies "
                          "the gains")
    if METHODS[method].gains_given and gains is None:
        logging.getLogger("orthoglide_ident").info(
            "no --gains: using the manufacturer's (nominal) gains %s", ", ".join(
                f"{j.name} {j.nominal_gain:.5g} {j.gain_unit}" for j in robot.joints))
    if args.payload_mass is not None and not (math.isfinite(args.payload_mass)
                                              and args.payload_mass > 0):
        raise ConfigError(f"--payload-mass must be a positive mass in kg, not {args.payload_mass}")
    progress = Stages() if shown() else None  # a terminal's stages; piped: none at all
    try:
        return identify(args.bags, payload_mass=args.payload_mass, method=method, gains=gains,
                        essential=args.essential, options=opts, model=robot,
                        validation_bags=args.validate, progress=progress)
    finally:
        if progress is not None:
            progress.close()


def _write_json(path: str, doc: dict) -> None:
    try:
        from orthoglide_ident.results import json_text

        Path(path).write_text(json_text(doc))
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None


def _consistent_set(res, flag: str):
    """The consistent standard parameters behind ``res``, or a one-line refusal saying why
    there are none (a partial answer: they need every gain)."""
    if res.consistency is None:
        why = "a partial answer" if not res.complete else "no consistent set was found"
        raise IdentificationError(f"{flag} not written: {why} (see the warnings above)")
    return res.consistency.answer.chi_st


def _write_urdf(path: str, res, args: argparse.Namespace) -> None:
    """The consistent identified model as a URDF (RobotModel.identified_urdf)."""
    _consistent_set(res, "--urdf-out")
    text = load_robot_from_args(args).identified_urdf(res.consistency.answer.chi_st,
                                                      [g.value for g in res.drive_gains])
    try:
        Path(path).write_text(text)
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
    logging.getLogger("orthoglide_ident").info("wrote %s", path)


def _write_mjcf(path: str, res, args: argparse.Namespace) -> None:
    """The consistent identified robot as an MJCF (model/mjcf_out.py)."""
    from orthoglide_ident.model.mjcf_out import write_mjcf

    _consistent_set(res, "--mjcf-out")
    notes = write_mjcf(path, load_robot_from_args(args), res.consistency.answer.chi_st,
                       [g.value for g in res.drive_gains])
    log = logging.getLogger("orthoglide_ident")
    log.info("wrote %s (the consistent parameters)%s", path, "".join(f"; {n}" for n in notes))


def _main(args: argparse.Namespace) -> int:
    prepare_outputs(args)  # a bad --out now, not after the work
    if args.command == "record":
        return ros_client.record(args)
    if args.command == "watch":
        return ros_client.watch(args)
    if args.command == "import":
        return import_command.run(args)
    if args.command == "excite" and getattr(args, "excite_handler", None):
        return args.excite_handler(args)  # excite run: the robot from its file, over ROS 2
    if args.command == "identify" and args.service:
        ros_client.identify_service(args)  # flags it cannot send: refused in one line
        return EXIT_OK
    if args.command in ("identify", "report") and not args.bags:
        raise ConfigError(
            f"{args.command}: give at least one BAG (or --service to ask the running node)"
        )
    if args.command in ("identify", "report"):
        _setup_logging(args.quiet)
        res = _run_identify(args)
        if args.command == "report":
            from orthoglide_ident.report import write_report

            try:
                paths = write_report(res, args.out)
            except OSError as exc:
                raise ConfigError(f"cannot write the report into {args.out}: "
                                  f"{exc.strerror or exc}") from None
            if args.mcap:
                from orthoglide_ident.view.report_mcap import write_report_mcap

                paths.append(write_report_mcap(res, args.mcap))
            print(res.to_text())
            print("\nwrote " + ", ".join(str(p) for p in paths))
        else:
            print(res.to_text())
        if args.json:
            _write_json(args.json, res.to_json())
        if args.urdf_out:
            _write_urdf(args.urdf_out, res, args)
        if args.mjcf_out:
            _write_mjcf(args.mjcf_out, res, args)
        return EXIT_OK
    if args.command == "info":
        from orthoglide_ident import bags

        texts = [bags.bag_info(p).to_text() for p in args.bags]
        print("\n\n".join(texts))
        return EXIT_OK
    if args.command == "reindex":
        from orthoglide_ident import bags

        for i, p in enumerate(args.bags):  # each bag's report as soon as it is repaired
            print(("\n" if i else "") + bags.reindex(p).to_text(), flush=True)
        return EXIT_OK
    if args.command == "excite":
        from orthoglide_ident.excite.cli import run_excite

        _setup_logging(False)
        return run_excite(args, load_robot_from_args(args))
    if args.command == "model":
        _setup_logging(True)
        bm = load_robot_from_args(args)
        print(bm.table())
        if args.json:
            _write_json(args.json, bm.to_json())
        return EXIT_OK
    raise ConfigError(f"unknown command {args.command}")


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``orthoglide-ident`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = _main(args)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return code
    except OrthoglideError as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # `orthoglide-ident ... | head -1`: the reader has what it wanted
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # a bug: say so in one line, traceback on request
        if os.environ.get("ORTHOGLIDE_DEBUG"):
            traceback.print_exc()
        print(f"{PROG}: internal error ({type(exc).__name__}: {exc}); set ORTHOGLIDE_DEBUG=1 "
              "for the traceback and report it", file=sys.stderr)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
