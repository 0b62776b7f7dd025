"""``labkit vision``: printable marker and board sheets, camera calibration, marker poses of an image."""

from __future__ import annotations

from labkit.exceptions import needs_extra


def add_commands(sub):
    """Add ``vision`` (with ``marker``, ``board``, ``calibrate``, ``detect``) to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sub.add_parser("vision", help="camera: print markers and boards, calibrate, detect markers",
                   build=_vision_arguments)


def _vision_arguments(sp):
    vs = sp.add_subparsers(dest="vision_command", required=True)
    m = vs.add_parser("marker", help="PDF of markers at true size")
    m.add_argument("ids", nargs="+", type=int, help="marker ids")
    m.add_argument("--size", type=float, default=40.0, help="side of the black square [mm] (default 40)")
    m.add_argument("--family", default="tag36h11", help="marker family (default tag36h11)")
    m.add_argument("--paper", default="a4", help="a4 or letter")
    m.add_argument("-o", "--output", default="markers.pdf", help="PDF to write")
    m.set_defaults(func=_cmd_marker)
    b = vs.add_parser("board", help="PDF of a calibration board at true size")
    b.add_argument("--pattern", default="charuco", choices=("charuco", "checkerboard"), help="board pattern")
    b.add_argument("--columns", type=int, default=7, help="squares (ChArUco) or inner corners (checkerboard) along x")
    b.add_argument("--rows", type=int, default=5, help="the same along y")
    b.add_argument("--square", type=float, default=30.0, help="square side [mm]")
    b.add_argument("--marker", type=float, default=22.0, help="ChArUco marker side [mm]")
    b.add_argument("--paper", default="a4")
    b.add_argument("-o", "--output", default="board.pdf")
    b.set_defaults(func=_cmd_board)
    c = vs.add_parser("calibrate", help="calibrate a camera from board images; writes a camera file")
    c.add_argument("images", nargs="+", help="image files of the board")
    c.add_argument("--pattern", default="charuco", choices=("charuco", "checkerboard"), help="board pattern")
    c.add_argument("--columns", type=int, default=7)
    c.add_argument("--rows", type=int, default=5)
    c.add_argument("--square", type=float, default=30.0, help="square side [mm]")
    c.add_argument("--marker", type=float, default=22.0, help="ChArUco marker side [mm]")
    c.add_argument("-o", "--output", default="camera.toml", help="camera file to write")
    c.set_defaults(func=_cmd_calibrate)
    d = vs.add_parser("detect", help="marker poses in an image")
    d.add_argument("image")
    d.add_argument("--camera", required=True, help="camera file (labkit vision calibrate)")
    d.add_argument("--size", type=float, default=40.0, help="marker side [mm]")
    d.add_argument("--family", default="tag36h11")
    d.set_defaults(func=_cmd_detect)


def _board(args):
    from labkit.vision import CharucoBoard, Checkerboard

    if args.pattern == "checkerboard":
        return Checkerboard(args.columns, args.rows, args.square / 1e3)
    return CharucoBoard(args.columns, args.rows, args.square / 1e3, args.marker / 1e3)


def _cmd_marker(args):
    from labkit.vision import marker_sheet

    print(marker_sheet(args.output, args.ids, args.size / 1e3, args.family, paper=args.paper))


def _cmd_board(args):
    from labkit.vision import board_sheet

    print(board_sheet(args.output, _board(args), paper=args.paper))


def _cmd_calibrate(args):
    with needs_extra("vision"):
        import cv2

    from labkit.vision import Camera

    images = [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in args.images]
    cal = Camera.calibrate([im for im in images if im is not None], _board(args))
    print(cal.to_dataframe().assign(image=[p for p, im in zip(args.images, images) if im is not None])
          .to_string(index=False))
    print(f"RMS reprojection error {cal.rms:.3f} px; {int(cal.flagged.sum())} image(s) flagged")
    print(cal.camera.save(args.output, rms_px=cal.rms, images=int(cal.used.sum())))


def _cmd_detect(args):
    import numpy as np

    with needs_extra("vision"):
        import cv2

    from labkit.vision import Camera, marker_poses

    camera = Camera.load(args.camera)
    for d in marker_poses(cv2.imread(args.image), camera, args.size / 1e3, args.family, on_ambiguous="keep"):
        p, u = d.position * 1e3, d.uncertainty * 1e3
        flag = " AMBIGUOUS" if d.ambiguous else ""
        print(f"id {d.id}: position {np.round(p, 1).tolist()} mm +- {np.round(u, 1).tolist()} mm (1 sigma), "
              f"tilt {np.degrees(d.tilt):.0f} deg{flag}")
