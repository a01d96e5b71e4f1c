"""Per photo, the localizer from the extracted skyline against the same from the mask's skyline (a given skyline).

``python experiments/ch1/given-skyline/compare.py EXTRACTED.json GIVEN.json [known|unknown]`` (two ``bench-real``
runs of one side; their rows of that fov mode, known if not named)."""
import json
import sys

extracted, given = (json.load(open(p)) for p in sys.argv[1:3])
mode = sys.argv[3] if len(sys.argv) > 3 else "known"
rows_e = {r["photo"]: r for r in extracted["photos"] if r["fov_mode"] == mode}
rows_g = {r["photo"]: r for r in given["photos"] if r["fov_mode"] == mode}


def best_xy(r):
    """The answer's place, given or withheld: the pose, else the best-scoring refined pose."""
    if r.get("pose"):
        return r["pose"][:2]
    poses = r.get("refined_poses") or []
    return min(poses, key=lambda p: p[7])[:2] if poses else None


def best_error(r):
    xy = best_xy(r)
    return None if xy is None else ((xy[0] - r["truth_xy"][0]) ** 2 + (xy[1] - r["truth_xy"][1]) ** 2) ** 0.5


def cell(r):
    err = best_error(r)
    mark = "answer" if r["status"] == "localized" else "withheld"
    return f"{mark:8s} {('%.0f' % err) if err is not None else '-':>7s} {r['confidence']:5.2f}"


print(f"fov {mode}. extracted: {extracted['commit']}; given (the mask's skyline): {given['commit']}")
print(f"{'photo':34s} | {'extracted: status, m, conf':26s} | {'given: status, m, conf':26s}")
counts = {k: 0 for k in ("e_best", "g_best", "e_right", "g_right", "e_wrong", "g_wrong")}
for key in sorted(rows_g):
    e, g = rows_e[key], rows_g[key]
    print(f"{key:34s} | {cell(e):26s} | {cell(g):26s}")
    for tag, r in (("e", e), ("g", g)):
        err = best_error(r)
        counts[f"{tag}_best"] += err is not None and err <= 1000
        if r["status"] == "localized":
            counts[f"{tag}_right" if r["error_m"] <= 1000 else f"{tag}_wrong"] += 1
n = len(rows_g)
print(f"\n{n} photos. Best place within 1 km (answered or withheld): extracted {counts['e_best']}, given {counts['g_best']}."
      f" Answered within 1 km: extracted {counts['e_right']}, given {counts['g_right']}; answered more than 1 km off:"
      f" extracted {counts['e_wrong']}, given {counts['g_wrong']}.")
