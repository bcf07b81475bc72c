#!/usr/bin/env python3
"""Generate the bundled knee scenes of the papers (docs/verification.md, "The papers' knee models")
from one parametric model.

    python3 scripts/knee_scenes.py          # writes scenes/knee-*.json

The papers' frontal-plane total knee replacement (Danek, Hlavacek, Nedoma, MCS 68 (2005) 271-300,
section 8.2 ("D05"); Danek et al., ICCSA 2004, LNCS 3044, 456-466; Danek et al., MCS 2007,
doi:10.1016/j.matcom.2007.01.013) was drawn from an X-ray; no coordinates were published. This
script builds a model of the same parts, sizes and boundary conditions (section about 0.1 m x
0.14 m, as the papers' figure axes):

- tibia (bone) clamped at its bottom (points 1-2), with a Ti6Al4V tray and a UHMWPE (Chirulen)
  insert bonded on its plateau; the fibula (bone) clamped at its bottom (points 3-4) and either
  bonded to the tibia (D05, ICCSA: one body "tibia + fibula") or its own body in contact with the
  tibia on the facet 11-12 (MCS 2007);
- femur (bone) with a CoCrMo femoral component bonded on the distal cut, loaded on its top
  (points 5-6) by 2.15 MPa along the femur's axis, held only by the two condylar contacts
  (7-8 medial, 9-10 lateral). Each condyle sits in a shallow groove of the insert (faces at
  8 degrees, a conforming insert); the condyle's curvature is the parabolic initial gap
  d^2 / (2 R), R = 0.1 m, touching at the middle of each face. The grooves let frictionless
  contact carry the horizontal part of a load along a tilted femur (with flat contact the
  papers' semi-coercive femur with g = 0 has no equilibrium, reference/paper-knee.md 4.1);
- the femoral cut angle (ICCSA 3, 5, 7 degrees): the distal cut stays horizontal (the joint line)
  and the femur's shaft leans by the cut angle, so the load along the femur's axis leans with it.

Every number taken from a paper is named in the scene's description; the rest (geometry, the
groove angle, R, the uncertain intervals) is ours and said to be.
"""

import json
import math
import os

MATERIALS = {
    # D05 8.2, ICCSA 4, MCS 2007 2 (same values in all three papers).
    "bone": {"E": 1.71e10, "nu": 0.25},
    "ti6al4v": {"E": 1.15e11, "nu": 0.3},
    "uhmwpe": {"E": 3.4e8, "nu": 0.4},
    "cocrmo": {"E": 2.08e11, "nu": 0.3},
}
LOAD = 2.15e6  # Pa on 5-6, all three papers.
GROOVE_DEG = 8.0  # inclination of the insert's groove faces (ours).
RADIUS = 0.1  # condyle radius in the parabolic initial gap (ours).

# Heights [m] (ours; the papers' figures span about 0.1 x 0.14 m).
Y_TRAY, Y_INSERT, Y_TOP = 0.055, 0.060, 0.072
Y_CUT = 0.080
CONDYLES = {"medial": -0.018, "lateral": 0.018}
HALF_GROOVE = 0.010
DEPTH = HALF_GROOVE * math.tan(math.radians(GROOVE_DEG))
FACE_H = 0.0006  # element size along the condylar contact (about 17 nodes per face).


def r(p):
    return [round(p[0], 9), round(p[1], 9)]


def femur_polygon(cut_deg):
    """CoCrMo component below the horizontal cut, the bone above it with the shaft leaning."""
    t = math.radians(cut_deg)
    axis = (math.sin(t), math.cos(t))
    perp = (math.cos(t), -math.sin(t))
    s0 = (0.0, 0.103)
    s1 = (s0[0] + 0.035 * axis[0], s0[1] + 0.035 * axis[1])
    w = 0.015
    top_right = (s1[0] + w * perp[0], s1[1] + w * perp[1])
    top_left = (s1[0] - w * perp[0], s1[1] - w * perp[1])
    bone = [
        (-0.028, Y_CUT),
        (0.028, Y_CUT),
        (0.028, 0.092),
        (s0[0] + w * perp[0], s0[1] + w * perp[1]),
        top_right,
        top_left,
        (s0[0] - w * perp[0], s0[1] - w * perp[1]),
        (-0.028, 0.092),
    ]
    return bone, top_right, top_left


def groove_points(x_c):
    """The outer edge, bottom and inner edge of a groove centred at x_c (left to right)."""
    return [(x_c - HALF_GROOVE, Y_TOP), (x_c, Y_TOP - DEPTH), (x_c + HALF_GROOVE, Y_TOP)]


def component_polygon():
    m, l = groove_points(CONDYLES["medial"]), groove_points(CONDYLES["lateral"])
    # Bottom from left to right: medial groove, intercondylar notch (3 mm up), lateral groove.
    bottom = m + [(-0.005, Y_TOP + 0.003), (0.005, Y_TOP + 0.003)] + l
    return bottom + [(0.028, Y_CUT), (-0.028, Y_CUT)]


def insert_polygon():
    m, l = groove_points(CONDYLES["medial"]), groove_points(CONDYLES["lateral"])
    top = [(-0.03, Y_TOP)] + m + l + [(0.03, Y_TOP)]
    return [(-0.03, Y_INSERT), (0.03, Y_INSERT)] + list(reversed(top))


def tibia_polygon():
    # Shaft 30 mm wide flaring to the 60 mm plateau; the lateral condyle's underside holds the
    # fibular facet between (0.02, 0.042) and (0.03, 0.045) (facing down, 17 degrees).
    return [
        (-0.015, 0.0),
        (0.015, 0.0),
        (0.015, 0.035),
        FACET[0],
        FACET[1],
        (0.03, Y_TRAY),
        (-0.03, Y_TRAY),
        (-0.03, 0.045),
        (-0.02, 0.042),
        (-0.015, 0.035),
    ]


FACET = ((0.02, 0.042), (0.03, 0.045))
FIBULA = [(0.028, 0.0), (0.038, 0.0), (0.038, 0.041), FACET[1], FACET[0], (0.025, 0.034), (0.028, 0.03)]


def faces():
    """(contact name, segment start, segment end) of the four condylar faces, left to right."""
    out = []
    for side, x_c in CONDYLES.items():
        a, b, c = groove_points(x_c)
        first, second = ("outer", "inner") if side == "medial" else ("inner", "outer")
        out.append((f"{side} condyle {first} face", a, b))
        out.append((f"{side} condyle {second} face", b, c))
    return out


def seg_key(name):
    return name.replace(" condyle ", "_").replace(" face", "")


def scene(name, description, cut_deg, friction, fibula_body, uncertain, search):
    bone, top_right, top_left = femur_polygon(cut_deg)
    tibia_body = "tibia"
    bodies = [
        {
            "name": tibia_body,
            "zones": [
                {"name": "tibia", "material": "bone", "polygon": [r(p) for p in tibia_polygon()]},
                {
                    "name": "tray",
                    "material": "ti6al4v",
                    "polygon": [r(p) for p in [(-0.03, Y_TRAY), (0.03, Y_TRAY), (0.03, Y_INSERT), (-0.03, Y_INSERT)]],
                },
                {"name": "insert", "material": "uhmwpe", "polygon": [r(p) for p in insert_polygon()]},
            ],
        },
        {
            "name": "femur",
            "zones": [
                {"name": "component", "material": "cocrmo", "polygon": [r(p) for p in component_polygon()]},
                {"name": "femur", "material": "bone", "polygon": [r(p) for p in bone]},
            ],
        },
    ]
    fibula_zone = {"name": "fibula", "material": "bone", "polygon": [r(p) for p in FIBULA]}
    if fibula_body:
        bodies.append({"name": "fibula", "zones": [fibula_zone]})
    else:
        bodies[0]["zones"].append(fibula_zone)
    segments = {
        "tibia_fixation": {"body": tibia_body, "from": [-0.015, 0.0], "to": [0.015, 0.0]},
        "fibula_fixation": {"body": "fibula" if fibula_body else tibia_body, "from": [0.028, 0.0], "to": [0.038, 0.0]},
        "femur_top": {"body": "femur", "from": r(top_right), "to": r(top_left)},
    }
    contacts = []
    for contact, a, b in faces():
        key = seg_key(contact)
        segments[f"insert_{key}"] = {"body": tibia_body, "from": r(a), "to": r(b)}
        segments[f"femur_{key}"] = {"body": "femur", "from": r(a), "to": r(b)}
        mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
        entry = {
            "name": contact,
            "between": [f"femur_{key}", f"insert_{key}"],
            "kind": "unilateral",
            "initial_gap": {"parabola": {"radius": RADIUS, "touch_at": r(mid)}},
        }
        entry.update(friction)
        contacts.append(entry)
    if fibula_body:
        segments["tibia_facet"] = {"body": tibia_body, "from": r(FACET[0]), "to": r(FACET[1])}
        segments["fibula_facet"] = {"body": "fibula", "from": r(FACET[1]), "to": r(FACET[0])}
        contacts.append(
            {
                "name": "tibiofibular joint",
                "between": ["fibula_facet", "tibia_facet"],
                "kind": "unilateral",
                "friction_coefficient": 0.02,
            }
        )
    regions = []
    for side, x_c in CONDYLES.items():
        # Insert under the groove: the top follows the two faces.
        dx = 0.004
        rise = dx * math.tan(math.radians(GROOVE_DEG))
        bottom_y = Y_TOP - DEPTH
        regions.append(
            {
                "name": f"{side} insert",
                "polygon": [
                    r(p)
                    for p in [
                        (x_c - dx, Y_TOP - DEPTH - 0.004),
                        (x_c + dx, Y_TOP - DEPTH - 0.004),
                        (x_c + dx, bottom_y + rise),
                        (x_c, bottom_y),
                        (x_c - dx, bottom_y + rise),
                    ]
                ],
                "normal": [0.0, 1.0],
            }
        )
    regions.append(
        {
            "name": "femoral bone above the cut",
            "polygon": [[-0.02, Y_CUT], [0.02, Y_CUT], [0.02, Y_CUT + 0.005], [-0.02, Y_CUT + 0.005]],
            "normal": [0.0, -1.0],
        }
    )
    contact_segments = [f"femur_{seg_key(c)}" for c, _, _ in faces()]
    refine = [{"segments": contact_segments, "max_size": FACE_H}]
    if fibula_body:
        refine.append({"segments": ["tibia_facet"], "max_size": 0.001})
    return {
        "version": 1,
        "name": name,
        "description": description,
        "bodies": bodies,
        "segments": segments,
        "materials": MATERIALS,
        "boundary": [
            {"segment": "tibia_fixation", "displacement": [0, 0]},
            {"segment": "fibula_fixation", "displacement": [0, 0]},
            {"segment": "femur_top", "pressure": LOAD},
        ],
        "contacts": contacts,
        "mesh": {"max_size": 0.003, "refine": refine},
        "criteria": {"regions": regions},
        "uncertain": uncertain,
        "search": search,
    }


COMMON = (
    "Total knee replacement, frontal section, after Danek et al. (MCS 2005 8.2, ICCSA 2004, "
    "MCS 2007). Papers: bone E 1.71e10 Pa nu 0.25, Ti6Al4V tray 1.15e11/0.3, UHMWPE insert "
    "3.4e8/0.4, CoCrMo femoral component 2.08e11/0.3; 2.15e6 Pa on the femur's top along its "
    "axis; tibia and fibula clamped; unilateral contact on both condyles. Ours: geometry (plane "
    "strain), insert grooves at 8 deg, condyle radius 0.1 m (parabolic gap), the intervals; "
    "see scripts/knee_scenes.py and docs/verification.md."
)

MATERIAL_UNCERTAINTY = [
    {"name": "insert E", "field": "materials.uhmwpe.E", "interval": [2.5e8, 4.5e8]},
    {"name": "bone E", "field": "materials.bone.E", "interval": [1.4e10, 2.0e10]},
    {"name": "load", "field": "boundary[2].pressure", "interval": [1.8e6, 2.5e6]},
]


def main():
    out_dir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes")
    scenes = {}
    scenes["knee-d05"] = scene(
        "Knee replacement of D05 (MCS 2005, 8.2)",
        COMMON
        + " D05: Tresca slip limit 1e5 Pa, fibula bonded to the tibia; D05's mesh had 3800 nodes, "
        "7200 elements, 62 contact nodes. Femoral cut 5 deg (ours).",
        5.0,
        {"slip_limit": 1.0e5},
        False,
        MATERIAL_UNCERTAINTY
        + [{"name": "medial slip limit", "field": "contacts[medial condyle outer face].slip_limit", "interval": [0.5e5, 1.5e5]}],
        {"criteria": ["phi5", "phi6"], "budget": 80, "seed": 1},
    )
    scenes["knee-mcs2007-coulomb"] = scene(
        "Knee replacement of MCS 2007 with Coulomb friction",
        COMMON
        + " MCS 2007: the fibula its own body in contact with the tibia, Coulomb friction; F is not "
        "given: ours 0.07 on the condyles (uncertain in [0.04, 0.10]), 0.02 tibia-fibula. "
        "Femur axis vertical (ours; MCS 2007 has no cut study).",
        0.0,
        {"friction_coefficient": 0.07},
        True,
        [MATERIAL_UNCERTAINTY[0], MATERIAL_UNCERTAINTY[2]]
        + [
            {"name": f"F {c}", "field": f"contacts[{c}].friction_coefficient", "interval": [0.04, 0.10]}
            for c, _, _ in faces()
        ],
        {"criteria": ["phi5", "phi6"], "budget": 150, "seed": 1},
    )
    for cut in (3, 5, 7):
        scenes[f"knee-cut-{cut}"] = scene(
            f"Knee replacement, femoral cut {cut} degrees (ICCSA 2004)",
            COMMON
            + f" ICCSA 2004: femoral cut {cut} deg (cases 3, 5, 7), frictionless (g = 0), fibula "
            "bonded to the tibia; the paper's stress extremes and ours are compared in "
            "docs/verification.md.",
            float(cut),
            {"slip_limit": 0.0},
            False,
            MATERIAL_UNCERTAINTY,
            {"criteria": ["phi3", "phi5"], "budget": 40, "seed": 1},
        )
    for name, value in scenes.items():
        with open(os.path.join(out_dir, f"{name}.json"), "w") as f:
            json.dump(value, f, indent=2)
            f.write("\n")
        print(f"scenes/{name}.json")


if __name__ == "__main__":
    main()
