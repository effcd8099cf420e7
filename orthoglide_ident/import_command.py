"""``orthoglide-ident import CSV... --out BAG``: a CSV log as a tagged bag (bags/csv_import.py).

Kept beside cli.py so that the command's flags and help live in one place; cli.py adds the
sub-parser and calls :func:`run`.
"""
from __future__ import annotations

import argparse

EXAMPLE = """\
example (the Franka Panda log of tests/fixtures/panda_gaz2019, joint torques in N·m):
  orthoglide-ident import panda_a.csv.xz --out panda_a \\
      --effort '{joint}.tau' --velocity '{joint}.qd' --effort-unit N·m
  orthoglide-ident identify --robot panda.urdf --method wls panda_a

  header of the CSV:  t,panda_joint1.q,...,panda_joint1.qd,...,panda_joint1.tau,...

the same map as a YAML file (--map FILE; flags given on the command line win):
  time: t
  time_unit: s                # s | ms | us | ns
  joints: [j1, j2]            # default: every column the position template matches
  position: "{joint}.q"       # a template, or one column per joint: "q1,q2"
  velocity: "{joint}.qd"      # optional: none = no recorded velocity (NaN in the bag)
  effort: "{joint}.tau"
  effort_unit: N·m            # A | mA (a current) or N·m (Nm) | N (a torque / force)
  angle_unit: rad             # deg: positions and velocities in degrees
  condition: loaded
  payload_mass: 1.5           # kg; payload_frame, payload_com "x y z", payload_inertia
  # per joint instead of templates:
  # joints: {j1: {position: q1, effort: tau1}, j2: {position: q2, effort: tau2}}

A torque (N·m, N) is written as the JointState effort with the tag orthoglide.effort_unit:
torque; identification divides it by the robot's nominal gains (1 for a bare URDF), so the
"gains" it finds are the torque's calibration. Several CSV files make one bag: pieces of one
log in the order given (a logger's rotated files), time increasing across them; import runs
with different tags (unloaded, loaded) into different bags. .csv.gz and .csv.xz are read as
they are."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "import", help="write a tagged bag from CSV logs (a column map by flags or YAML)",
        description="Read CSV logs (a time column, joint positions, optional velocities, "
                    "currents or torques) and write one tagged rosbag2 bag in the ros2_control "
                    "layout (/joint_states: position, velocity, effort; header.stamp from the "
                    "time column), identified as a recorded bag is.",
        epilog=EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv", nargs="+", metavar="CSV", help="CSV files (.csv, .csv.gz, .csv.xz)")
    p.add_argument("--out", required=True, metavar="BAG", help="the bag directory to write")
    p.add_argument("--map", metavar="YAML", help="column map file (keys as the flags below)")
    p.add_argument("--time", metavar="COL", help="the time column (default t)")
    p.add_argument("--time-unit", metavar="UNIT", help="s, ms, us or ns (default s)")
    p.add_argument("--joints", metavar="J1,J2,...",
                   help="joint names in the bag (default: those the position template finds "
                        "in the header)")
    p.add_argument("--position", metavar="TEMPLATE|COLS",
                   help="position columns: a template with {joint} (default {joint}.q) or one "
                        "column per joint, comma-separated")
    p.add_argument("--velocity", metavar="TEMPLATE|COLS",
                   help="recorded velocity columns (default none)")
    p.add_argument("--effort", metavar="TEMPLATE|COLS",
                   help="current or torque columns (default {joint}.effort)")
    p.add_argument("--effort-unit", metavar="UNIT",
                   help="A or mA (a current); N·m, Nm or N (a torque or force): required")
    p.add_argument("--angle-unit", metavar="UNIT",
                   help="rad (default; a prismatic joint's m as they are) or deg")
    p.add_argument("--prismatic", metavar="J1,J2,...",
                   help="joints whose positions are lengths (m): --angle-unit deg leaves them")
    p.add_argument("--delimiter", metavar="D",
                   help="',', ';', tab or space (default: from the header line)")
    p.add_argument("--condition", choices=("unloaded", "loaded"), help="the tag (default unloaded)")
    p.add_argument("--payload-mass", type=float, metavar="KG", help="the weighed payload (loaded)")
    p.add_argument("--payload-frame", metavar="LINK", help="the link the payload is fixed to")
    p.add_argument("--payload-com", metavar="X,Y,Z",
                   help="its centre of mass in that frame, m (or 'X Y Z')")
    p.add_argument("--payload-inertia", metavar="IXX,IXY,IXZ,IYY,IYZ,IZZ",
                   help="its inertia about the centre of mass, kg·m² (or space-separated)")
    p.add_argument("--current-sampling", choices=("held", "sampled", "auto"),
                   help="how the current relates to its time: held over the step that follows "
                        "(a controller at the log rate), sampled at the time from a faster loop "
                        "(a logger slower than its controller), auto (default: untagged, "
                        "identify's current_sampling option decides)")


def run(args: argparse.Namespace) -> int:
    """Import; print what was written (stdout). Errors propagate as OrthoglideError."""
    from orthoglide_ident.bags.csv_import import ColumnMap, import_csv
    from orthoglide_ident.flags import parse_vector

    cmap = ColumnMap.from_yaml(args.map) if args.map else ColumnMap()
    flags = {k: getattr(args, k) for k in (
        "time", "time_unit", "joints", "position", "velocity", "effort", "effort_unit",
        "angle_unit", "delimiter", "condition", "payload_mass", "payload_frame", "payload_com",
        "payload_inertia", "prismatic", "current_sampling")}
    given = {k: v for k, v in flags.items() if v is not None}
    for key, n in (("payload_com", 3), ("payload_inertia", 6)):
        if key in given:  # the flag named in its error
            given[key] = parse_vector(given[key], n, "--" + key.replace("_", "-"))
    if given:
        cmap = cmap.with_source(f"{args.map} and the flags" if args.map else "the flags"
                                ).with_values(**given)
    print(import_csv(args.csv, args.out, cmap).to_text())
    return 0
