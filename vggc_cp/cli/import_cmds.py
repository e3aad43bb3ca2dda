"""``vggc-cp import LAYOUT ...``: recordings (images + log, video + log, robomimic HDF5,
LeRobot folder) into a trace. One sub-command per registered importer; each layout's own
arguments come from its registry entry (:mod:`vggc_cp.importers`)."""

from __future__ import annotations

import os
from pathlib import Path

from vggc_cp.importers import IMPORTERS


def register(sub) -> None:
    p = sub.add_parser("import", help="turn recordings (images, video, robomimic HDF5, LeRobot) "
                                      "into a trace .npz",
                       description="Turn a recording into a trace .npz (docs/FORMATS.md, "
                                   "'Recordings in'; README, 'Bring your own recordings').")
    layouts = p.add_subparsers(dest="layout", metavar="LAYOUT")
    layouts.required = True
    for importer in IMPORTERS.values():
        q = layouts.add_parser(importer.name, help=importer.help,
                               description=importer.description.replace("``", ""))
        for arg in importer.arguments:
            if arg.name.startswith("--"):
                q.add_argument(arg.name, dest=arg.dest, required=arg.required,
                               metavar=arg.metavar, help=arg.help)
            else:
                q.add_argument(arg.dest, metavar=arg.metavar, help=arg.help)
        q.add_argument("-o", "--output", required=True, help="trace .npz to write")
        q.add_argument("--size", default=None, metavar="PX|WxH",
                       help="downsample every frame to PX x PX or W x H pixels by area "
                            "averaging (default: the recording's size)")
        q.add_argument("--map", default=None, metavar="FILE",
                       help="JSON object or CSV (label,action) mapping the recording's labels "
                            "to pick*/place* action names (default: the labels must already "
                            "begin with pick or place)")
        q.add_argument("--quiet", action="store_true", help="print nothing on success")
        q.set_defaults(func=cmd_import, importer=importer.name)


def cmd_import(args) -> int:
    from vggc_cp.importers import ImportConfig, get_importer, parse_size, read_label_map
    from vggc_cp.safeio import TEMP_MARK, check_input, check_output, temp_file
    from vggc_cp.trace import save_trace, summarize

    importer = get_importer(args.importer)
    inputs = {}
    for arg in importer.arguments:
        value = getattr(args, arg.dest)
        if not arg.name.startswith("--") and value is not None:
            if arg.dest != "folder":
                check_input(value, arg.dest)
            inputs[arg.dest] = str(value)
    if args.map is not None:
        check_input(args.map, "--map")
        inputs["map"] = args.map
    check_output(args.output, "--output", inputs)
    out = Path(args.output)
    # frames beyond the memory cap spill into a temporary file beside the output
    with temp_file(out.parent, f".{out.name}{TEMP_MARK}", ".frames") as spool:
        config = ImportConfig(size=parse_size(args.size) if args.size is not None else None,
                              label_map=read_label_map(args.map) if args.map else {},
                              label_map_file=args.map, spool=spool)
        trace = importer.read(config, **{a.dest: getattr(args, a.dest)
                                         for a in importer.arguments})
        save_trace(trace, args.output)
        info = summarize(trace)
        source = trace.meta["source"]["file"]
        del trace  # the frames' memory map, before the file goes
    if not args.quiet:
        h, w = info["image_size"]
        print(f"imported       {importer.name}: {os.path.basename(str(source))}")
        print(f"trace          N = {info['observations']} ({h}x{w} RGB), |D| = "
              f"{info['transitions']}, {info['episodes']} episodes, |A| = {info['actions']}")
        print(f"wrote          {args.output}")
    return 0
