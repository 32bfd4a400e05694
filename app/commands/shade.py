"""``sheer shade``: find the foundation that matches a skin, and see which skins a range serves badly.

- ``sheer shade match (--rgb R,G,B | --lab L,a,b | --face FACE_DIR | --photo P [--region x,y,w,h])
  [--target TARGET] [--illuminant NAME] [--store-light NAME|FILE] [--top N] [--library PATH] [--json]``:
  the skin is fitted with the biophysical skin model (:mod:`km.skin`), every foundation of the library is
  put on it at its best thickness (:mod:`shade.match`), and the shades are ranked by ΔE2000 against the
  target under the illuminant, with the metamerism check under daylight (D65), the store's light and warm
  indoor light (A). A photograph's skin is read on the cheeks of its largest face, found by MediaPipe's
  landmarks (:mod:`capture.skin`: the kiosk's *Find my foundation* reads hers the same way), and the
  match says how far it can be trusted (``confidence``: how close the skin model came to the colour).
- ``sheer shade coverage [--library PATH] --out coverage.png [--skins N] [--json]``: a population of
  skins, the best shade of the library for each, a plot of the skin-tone plane coloured by that ΔE2000
  and the mixture of existing shades that would fill the largest gap (:mod:`shade.coverage`).

Without ``--library`` Sheer's default library is used. Bad input (a typed colour the skin model cannot
produce, a photograph's colour that is not skin at all, a region outside the photograph, no face and no
region, a library without foundation…) is reported in one line, exit status 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import argparse

    from app.commands import Subcommands
    from km.skin import SkinFit
    from shade.coverage import Coverage

#: A typed colour (--rgb, --lab) or a face folder's further than this (ΔE2000) from every skin the model can
#: make is refused as "not a skin colour".
MAX_FIT_DE2000 = 10.0
#: A photograph's reading is matched however far it is, with a low confidence (light, white balance and
#: make-up move a photographed skin far from the model's); further than this it is not skin (a wall, a
#: background) and is refused.
MAX_PHOTO_DE2000 = 20.0


def register(sub: Subcommands) -> None:
    """Add ``sheer shade match`` and ``sheer shade coverage`` to the sub-command parsers ``sub``."""
    from app.commands import LIBRARY_HELP, LazyHelp, command_group

    ssub = command_group(sub, "shade", "find the foundation that matches a skin; a range's coverage", __doc__)

    q = ssub.add_parser("match", help="rank the library's foundations on a skin")
    src = q.add_mutually_exclusive_group(required=True)
    src.add_argument("--rgb", help="the skin as R,G,B (0-255, encoded in --space; default sRGB)")
    src.add_argument("--lab", help="the skin as CIELAB L,a,b (D65)")
    src.add_argument("--face", type=Path, help="a face folder from 'sheer capture' (its fitted diffuse colour)")
    src.add_argument("--photo", type=Path, help="a photograph (the cheeks of its largest face, or --region)")
    q.add_argument("--region", help="with --photo: the skin's region x,y,w,h in pixels from the top-left")
    q.add_argument("--space", default="sRGB", help="with --rgb: colour-science's name of the RGB space "
                                                   "(sRGB, Display P3, Adobe RGB (1998)…)")
    q.add_argument("--no-checker", action="store_true", help="with --photo: do not look for a colour checker")
    q.add_argument("--target", default="own",
                   help=LazyHelp("%(targets)s (default %(default)s: a foundation that disappears, the others a "
                                 "step from it), lab:L,a,b or rgb:R,G,B", targets=_targets))
    q.add_argument("--illuminant", default="D65", help="light the shades are ranked under (default D65)")
    q.add_argument("--store-light", default=None,
                   help=LazyHelp("the store's light for the metamerism check: a CIE name (default %(store)s) or a "
                                 "CSV spectrum file wavelength_nm,power", store=_store_light))
    q.add_argument("--oxygenation", type=float, default=None, help="blood oxygenation held in the fit (0-1)")
    q.add_argument("--top", type=int, default=None, help="show the N best shades (default all)")
    q.add_argument("--library", type=Path, help=LIBRARY_HELP)
    q.add_argument("--json", action="store_true", help="print JSON (with the fitted skin's parameters and spectrum)")
    q.set_defaults(func=run_match)

    q = ssub.add_parser("coverage", help="which skins a range of foundations serves badly (plot and gap shade)")
    q.add_argument("--library", type=Path, help=LIBRARY_HELP)
    q.add_argument("--out", type=Path, required=True, help="the coverage plot (.png)")
    q.add_argument("--skins", type=int, default=1000, help="population size (default 1000)")
    q.add_argument("--seed", type=int, default=0, help="population seed (default 0)")
    q.add_argument("--illuminant", default="D65", help="light the colours are compared under (default D65)")
    q.add_argument("--threshold", type=float, default=None, help="ΔE2000 above which a skin is poorly served "
                                                                 "(default 2)")
    q.add_argument("--json", action="store_true", help="print JSON")
    q.set_defaults(func=run_coverage)


def _targets() -> list[str]:
    """The named targets (:data:`shade.match.TARGET_SHIFTS`; imported when the help is shown)."""
    from shade.match import TARGET_SHIFTS

    return list(TARGET_SHIFTS)


def _store_light() -> list[str]:
    """The store's light by default (:data:`shade.match.DEFAULT_STORE_LIGHT`)."""
    from shade.match import DEFAULT_STORE_LIGHT

    return [DEFAULT_STORE_LIGHT]


def _numbers(text: str, n: int, what: str) -> list[float]:
    from core.errors import SheerError

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != n or not all(abs(v) < float("inf") for v in values):
        raise SheerError(f"{what}: expected {n} numbers separated by commas, got {text!r}")
    return values


def _bank(library: Path | None) -> Any:
    from km.library import Library, default_library
    from shade.match import ShadeBank, foundations

    lib = default_library() if library is None else Library.load(library)
    return ShadeBank.from_materials(foundations(lib))


def skin_from_args(args: argparse.Namespace) -> tuple[SkinFit, dict[str, Any]]:
    """Fit the skin model to the colour the arguments give; returns the fit and where it came from.

    Raises:
        core.errors.SheerError: malformed values, an unreadable source, no face in a photograph, or a colour
            further than :data:`MAX_FIT_DE2000` (a photograph's: :data:`MAX_PHOTO_DE2000`) from every skin
            of the model.
    """
    import numpy as np

    from core.errors import SheerError
    from km.skin import DEFAULT_OXYGENATION, fit_skin

    oxygenation = DEFAULT_OXYGENATION if args.oxygenation is None else args.oxygenation
    if args.region is not None and args.photo is None:
        raise SheerError("--region needs --photo")
    source: dict[str, Any]
    if args.rgb is not None:
        rgb = np.asarray(_numbers(args.rgb, 3, "--rgb"))
        if (rgb < 0).any() or (rgb > 255).any():
            raise SheerError(f"--rgb: each value must be in 0..255, got {args.rgb}")
        linear = _to_linear_srgb(rgb / 255.0, args.space)
        source = {"kind": "rgb", "value": rgb.tolist(), "space": args.space, "linear_srgb": linear.tolist()}
        fit = fit_skin(linear_rgb=linear, oxygenation=oxygenation)
    elif args.lab is not None:
        lab = _numbers(args.lab, 3, "--lab")
        source = {"kind": "lab", "value": lab}
        fit = fit_skin(lab, oxygenation=oxygenation)
    elif args.face is not None:
        from capture.face import load_face

        diffuse = np.asarray(load_face(args.face).params.diffuse, dtype=np.float64)
        source = {"kind": "face", "folder": str(args.face), "linear_srgb": diffuse.tolist(),
                  "note": "the capture's fitted diffuse colour (linear sRGB reflectance)"}
        fit = fit_skin(linear_rgb=diffuse, oxygenation=oxygenation)
    else:
        photo = _photo_skin(args)
        source = {"kind": "photo", "path": str(args.photo), **photo.to_json()}
        fit = fit_skin(linear_rgb=photo.linear_rgb, oxygenation=oxygenation)
    limit = MAX_PHOTO_DE2000 if source["kind"] == "photo" else MAX_FIT_DE2000
    if fit.residual_de2000 > limit:
        lab = ", ".join(f"{v:.1f}" for v in fit.target_lab)
        raise SheerError(f"the colour (Lab {lab}) is not a skin colour the skin model can produce: the closest "
                         f"skin is ΔE2000 {fit.residual_de2000:.1f} away (at most {limit:g} is accepted"
                         + (" from a photograph" if source["kind"] == "photo" else "") + ")")
    return fit, source


def _photo_skin(args: argparse.Namespace) -> Any:
    """The skin read from ``--photo``: ``--region``'s pixels, else the cheeks of its largest face.

    The face's reading is :func:`capture.skin.skin_from_portrait`, the kiosk's (MediaPipe's landmarks).
    """
    from core.errors import SheerError

    if args.region is None:
        from capture.skin import skin_from_portrait

        return skin_from_portrait(args.photo, use_checker=not args.no_checker)
    from shade.photo import skin_from_photo

    x, y, w, h = _numbers(args.region, 4, "--region")
    if not all(float(v).is_integer() for v in (x, y, w, h)):
        raise SheerError(f"--region: x,y,w,h must be whole pixels, got {args.region}")
    return skin_from_photo(args.photo, (int(x), int(y), int(w), int(h)), use_checker=not args.no_checker)


def _to_linear_srgb(encoded: Any, space: str) -> Any:
    """Encoded RGB in [0, 1] of a colour-science RGB space → linear sRGB (CAT02 to D65 when needed)."""
    import colour
    import numpy as np

    from core.errors import SheerError
    from km.srgb import srgb_decode

    if space.lower() == "srgb":
        return srgb_decode(np.asarray(encoded, dtype=np.float64))
    if space not in colour.RGB_COLOURSPACES:
        raise SheerError(f"--space: unknown RGB space {space!r} (e.g. sRGB, Display P3, Adobe RGB (1998))")
    with colour.domain_range_scale("reference"):
        return np.asarray(colour.RGB_to_RGB(encoded, colour.RGB_COLOURSPACES[space], colour.RGB_COLOURSPACES["sRGB"],
                                            chromatic_adaptation_transform="CAT02", apply_cctf_decoding=True,
                                            apply_cctf_encoding=False), dtype=np.float64)


def _lights(args: argparse.Namespace) -> tuple[str, tuple[str, ...]]:
    from shade.match import DEFAULT_STORE_LIGHT, resolve_light

    main = resolve_light(args.illuminant)
    store = resolve_light(args.store_light or DEFAULT_STORE_LIGHT)
    return main, tuple(dict.fromkeys(("D65", store, "A")))


def _credits() -> list[str]:
    """The credits of the data the skin model is made of (the haemoglobin spectra)."""
    from core.assets import credit_for
    from km.skin import HAEMOGLOBIN_ASSET

    credit = credit_for(HAEMOGLOBIN_ASSET)
    return [credit] if credit else []


def run_match(args: argparse.Namespace) -> int:
    """Rank the library's foundations on the skin and print a table or JSON; returns 0."""
    from core.errors import SheerError
    from shade.match import confidence, make_target, match_shades

    if args.top is not None and args.top < 1:
        raise SheerError(f"--top must be at least 1, got {args.top}")
    main, lights = _lights(args)
    bank = _bank(args.library)
    fit, source = skin_from_args(args)
    target = make_target(args.target, fit)
    ranked = match_shades(fit.reflectance, target.reflectance, bank, illuminant=main, lights=lights)
    shown = ranked[: args.top] if args.top else ranked
    note = source.get("note", "")
    trust = confidence(fit)
    if args.json:
        out = {"skin": fit.to_json(), "source": source, "target": target.to_json(), "illuminant": main,
               "lights": list(lights), "note": note, "confidence": trust.to_json(), "credits": _credits(),
               "shades": [{**s.to_json(), "rank": i + 1, "metamerism": s.metamerism_words()}
                          for i, s in enumerate(shown)]}
        json.dump(out, sys.stdout, indent=2, ensure_ascii=False)
        print()
        return 0
    p = fit.params
    print(f"skin: melanin {p.melanin:.3f}, blood {p.blood:.4f}, scattering {p.scattering:.2f}, "
          f"pheomelanin {p.pheomelanin:.2f}, oxygenation {p.oxygenation:.2f}; Lab "
          f"{', '.join(f'{v:.1f}' for v in fit.lab)}; fit ΔE2000 {fit.residual_de2000:.2f}")
    print(f"confidence: {trust.level} — {trust.words}")
    if note:
        print(f"note: {note}")
    print(f"target: {target.name}; ranked under {main}; metamerism checked under {', '.join(lights)}")
    header = f"{'#':>2}  {'shade':<28} {'µm':>6} {'ΔE00':>6}  " + " ".join(f"{n[:10]:>10}" for n in lights) \
        + "  swatch"
    print(header)
    for i, s in enumerate(shown, 1):
        cells = " ".join(f"{s.de2000_by_illuminant[n]:>10.2f}" for n in lights)
        flag = "  ⚠ metameric" if s.metameric else ""
        print(f"{i:>2}  {s.name:<28} {s.thickness_um:>6.1f} {s.de2000:>6.2f}  {cells}  {s.swatch_hex}{flag}")
    return 0


def plot_coverage(cov: Coverage, out: Path) -> None:
    """The skin-tone plane (L* against hue angle, and ITA°) coloured by each skin's best ΔE2000, as a PNG.

    Written atomically; the gap's skins are ringed and the suggested shade named in the title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import numpy as np
    from matplotlib.figure import Figure

    from core.atomicio import atomic_write_with

    fig = Figure(figsize=(11, 4.8), dpi=100)
    ax1, ax2 = fig.subplots(1, 2)
    vmax = max(float(np.percentile(cov.best_de2000, 99)), cov.threshold * 2)
    for ax, y, label in ((ax1, cov.lab[:, 0], "L* (lightness)"), (ax2, cov.ita_deg, "ITA° (individual typology angle)")):
        sc = ax.scatter(cov.hue_deg, y, c=cov.best_de2000, cmap="viridis_r", vmin=0, vmax=vmax, s=9)
        if cov.gap is not None:
            ax.scatter(cov.hue_deg[cov.gap.gap_skins], y[cov.gap.gap_skins], facecolors="none", edgecolors="red",
                       s=30, lw=0.7, label="largest gap")
            ax.legend(fontsize=8, loc="lower right")
        ax.set_xlabel("hue angle h_ab (degrees)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.colorbar(sc, ax=[ax1, ax2], label=f"best ΔE2000 in the range ({cov.illuminant})")
    title = (f"{len(cov.best_de2000)} skins: {100 * cov.served_fraction:.0f} % served within ΔE2000 "
             f"{cov.threshold:g} by {len(cov.names)} foundations")
    if cov.gap is not None:
        recipe = " + ".join(f"{100 * c:.0f} % {n}" for n, c in cov.gap.recipe.items())
        title += (f"\nsuggested shade for the gap ({cov.gap.gap_skins.size} skins): {recipe}; "
                  f"mean ΔE2000 {cov.gap.mean_de_before:.2f} → {cov.gap.mean_de_after:.2f}")
    fig.suptitle(title, fontsize=10)
    fig.text(0.01, 0.01, "Skin model data: " + "; ".join(_credits()), fontsize=6, color="0.4")
    atomic_write_with(out, lambda fh: fig.savefig(fh, format="png"))


def run_coverage(args: argparse.Namespace) -> int:
    """Compute the coverage, write the plot, print a summary or JSON; returns 0."""
    from core.errors import SheerError
    from shade.coverage import POORLY_SERVED_DE2000, coverage
    from shade.match import resolve_light

    if args.out.suffix.lower() != ".png":
        raise SheerError(f"--out must name a .png file (got {args.out})")
    if not args.out.parent.is_dir():
        raise SheerError(f"--out: the folder {args.out.parent} does not exist")
    threshold = POORLY_SERVED_DE2000 if args.threshold is None else args.threshold
    bank = _bank(args.library)
    cov = coverage(bank, args.skins, seed=args.seed, illuminant=resolve_light(args.illuminant), threshold=threshold)
    plot_coverage(cov, args.out)
    if args.json:
        json.dump({**cov.to_json(), "plot": str(args.out), "credits": _credits()}, sys.stdout, indent=2,
                  ensure_ascii=False)
        print()
        return 0
    js = cov.to_json()
    print(f"{js['skins']} skins (ITA° {js['ita_range_deg'][0]} to {js['ita_range_deg'][1]}), "
          f"{100 * cov.served_fraction:.0f} % served within ΔE2000 {threshold:g} under {cov.illuminant}")
    for name, count in js["best_counts"].items():
        print(f"  {name:<28} best for {count} skins")
    if cov.gap is not None:
        recipe = " + ".join(f"{100 * c:.0f} % {n}" for n, c in cov.gap.recipe.items())
        print(f"largest gap: {cov.gap.gap_skins.size} skins; suggested shade {recipe}: mean ΔE2000 "
              f"{cov.gap.mean_de_before:.2f} → {cov.gap.mean_de_after:.2f}, {cov.gap.served_after} then served")
    print(f"plot: {args.out}")
    return 0
