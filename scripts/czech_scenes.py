#!/usr/bin/env python3
"""Generate the bundled scenes of the Czech text's biomechanics models, FGCS's thermo-elastic
contact model, the sagittal knee section of MCS 2007 and the D03 model problem
(docs/verification.md, "The Czech text's models"; issue 49 item 3).

    python3 scripts/czech_scenes.py          # writes scenes/hip-replacement.json, ...

The papers publish materials, loads and the kind of each boundary condition, never coordinates
(their geometry was drawn from X-rays or given only as node numbers). Every number taken from a
paper is named in the scene's description with its source; the geometry, the uncertain intervals
and the search settings are ours and said to be. Sizes follow the papers' figure axes where
they have any. Lines refer to papers/000_c5a0b0f1845f98aa.txt (CZ = the Czech text).

- hip-replacement (CZ 1590-1637): bone E 2e9 Pa nu 0.3, stem and cup E 2e10 Pa nu 0.3, femur
  clamped, bilateral contact (a roller: CZ's Gamma_o) on the pelvis's plane of symmetry,
  unilateral contact head-cup, 0.4e6 Pa on the top.
- lower-limb-cartilage (CZ 1652-1674): bone 1.71e10/0.25, cartilage 0.492e9/0.1, zero
  displacement, bilateral contact (a roller on the femur's shaft and the tied tibia-fibula
  joint), unilateral contact cartilage-cartilage, 1e6 Pa on the femur's top.
- tibia-marrow (CZ 1675-1775): bone 1.71e10/0.25, marrow 2e6/0.49 (P1 locks at nu = 0.49: the
  scene warns; `mesh.element: "mixed"` is the remedy, compared in crates/core/tests/engine/czech_models.rs; the
  scene stays P1 while mixed has no exact derivatives), clamped bottom, 0.2e7 Pa on
  the plateau, bilateral (tied) contact marrow-bone. The text's colour-bar extremes are compared
  in crates/core/tests/engine/czech_models.rs.
- thermo-contact-fault (FGCS 2006, (2.1)-(2.13), (4.7)-(4.15)): heat with uncertain
  conductivity kappa, heat source W, boundary temperature T1 and expansion beta, Tresca contact
  on a fault; FGCS section 5 gives no thermal data, so all thermal numbers are ours.
- knee-sagittal (MCS 2007, Fig. 1b; materials and load of scripts/knee_scenes.py).
- d03-model-problem (D03 section 5, 3590-3600): three regions E 1e10 nu 0.3, zero displacement,
  0.18e7 Pa, bilateral and two unilateral contact boundaries (frictionless).
"""

import json
import math
import os

from knee_scenes import LOAD as KNEE_LOAD
from knee_scenes import MATERIALS as KNEE_MATERIALS
from knee_scenes import RADIUS as KNEE_RADIUS
from knee_scenes import r


def arc(centre, radius, a0, a1, n):
    """n + 1 points on a circle from angle a0 to a1 (degrees)."""
    return [
        (
            centre[0] + radius * math.cos(math.radians(a0 + (a1 - a0) * i / n)),
            centre[1] + radius * math.sin(math.radians(a0 + (a1 - a0) * i / n)),
        )
        for i in range(n + 1)
    ]


def poly(points):
    return [r(p) for p in points]


def seg(body, a, b):
    return {"body": body, "from": r(a), "to": r(b)}


def path(body, points):
    return {"body": body, "path": poly(points)}


def box(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


OURS = "Ours: the geometry (plane strain), the uncertain intervals and the search settings; see scripts/czech_scenes.py and docs/verification.md."


def hip():
    """CZ model 1: a femoral stem with its head in an acetabular cup set in the pelvis."""
    rh, rc = 0.022, 0.028  # head and cup's outer radius (ours)
    n = 12
    head = arc((0, 0), rh, 0, 180, n)
    stem = [(0.006, -0.15), (0.006, -0.03)] + head + [(-0.006, -0.03), (-0.006, -0.15)]
    femur_bone = [
        (-0.02, -0.2),
        (0.02, -0.2),
        (0.02, -0.03),
        (0.006, -0.03),
        (0.006, -0.15),
        (-0.006, -0.15),
        (-0.006, -0.03),
        (-0.02, -0.03),
    ]
    cup = [(rh, 0.0)] + arc((0, 0), rc, 0, 180, n) + arc((0, 0), rh, 180, 0, n)[:-1]
    pelvis = [(rc, 0.0), (0.06, 0.0), (0.06, 0.06), (-0.06, 0.06), (-0.06, 0.0)] + arc((0, 0), rc, 180, 0, n)[:-1]
    return {
        "version": 1,
        "name": "Total hip replacement (Czech text, model 1)",
        "description": "Total hip replacement after the Czech text (CZ 1590-1637): bone E 2e9 Pa nu 0.3, "
        "stem and cup E 2e10 Pa nu 0.3; femur clamped; bilateral contact (a roller) on the pelvis's "
        "plane of symmetry; unilateral (frictionless) contact between the head and the cup; "
        "pressure 0.4e6 Pa on the top. " + OURS + " Head radius 22 mm, cup 6 mm thick, femur 40 mm wide.",
        "bodies": [
            {
                "name": "femur",
                "zones": [
                    {"name": "femoral bone", "material": "bone", "polygon": poly(femur_bone)},
                    {"name": "stem", "material": "implant", "polygon": poly(stem)},
                ],
            },
            {
                "name": "pelvis",
                "zones": [
                    {"name": "cup", "material": "implant", "polygon": poly(cup)},
                    {"name": "pelvic bone", "material": "bone", "polygon": poly(pelvis)},
                ],
            },
        ],
        "segments": {
            "femur_fixation": seg("femur", (-0.02, -0.2), (0.02, -0.2)),
            "pelvis_symmetry": seg("pelvis", (-0.06, 0.06), (-0.06, 0.0)),
            "pelvis_top": seg("pelvis", (0.06, 0.06), (-0.06, 0.06)),
            "head": path("femur", head),
            "cup_inner": path("pelvis", head),
        },
        "materials": {"bone": {"E": 2.0e9, "nu": 0.3}, "implant": {"E": 2.0e10, "nu": 0.3}},
        "boundary": [
            {"segment": "femur_fixation", "displacement": [0, 0]},
            {"segment": "pelvis_symmetry", "roller": {}},
            {"segment": "pelvis_top", "pressure": 0.4e6},
        ],
        "contacts": [{"name": "head-cup", "between": ["head", "cup_inner"], "kind": "unilateral", "slip_limit": 0.0}],
        "mesh": {"max_size": 0.006, "refine": [{"segments": ["head"], "max_size": 0.002}]},
        "criteria": {
            "regions": [
                {"name": "calcar", "polygon": box(0.006, -0.06, 0.02, -0.03), "normal_at": [0.02, -0.045]},
                {"name": "bone at the stem's tip", "polygon": box(-0.02, -0.17, 0.02, -0.15), "normal_at": [0.02, -0.16]},
                {"name": "cup's pole", "polygon": box(-0.005, 0.022, 0.005, 0.028), "normal": [0.0, 1.0]},
            ],
            # The calcar is where a stiff stem shields the bone from stress: its mean von Mises
            # stress, a defined criterion (design §4.2), is searched beside Φ3 and Φ5.
            "defined": [{"name": "calcar_von_mises", "region": "calcar", "quantity": "von_mises"}],
        },
        "uncertain": [
            {"name": "bone E", "field": "materials.bone.E", "interval": [1.6e9, 2.4e9]},
            {"name": "implant E", "field": "materials.implant.E", "interval": [1.8e10, 2.2e10]},
            {"name": "load", "field": "boundary[2].pressure", "interval": [0.35e6, 0.45e6]},
        ],
        "search": {"criteria": ["phi3", "phi5", "calcar_von_mises"], "budget": 40, "seed": 1},
    }


def lower_limb():
    """CZ model 2: femur and tibia with cartilage layers in the knee joint, the fibula tied."""
    c, ra, t = (0.0, 0.06), 0.06, 0.003  # joint arc's centre and radius, cartilage thickness
    a0, a1, n = -140.0, -40.0, 20
    fem_in, joint, tib_out = (arc(c, ra - t, a0, a1, n), arc(c, ra, a0, a1, n), arc(c, ra + t, a1, a0, n))
    xr, xl = fem_in[-1], fem_in[0]
    femur_bone = fem_in + [(xr[0], 0.10), (0.015, 0.16), (0.015, 0.40), (-0.015, 0.40), (-0.015, 0.16), (xl[0], 0.10)]
    femoral_cartilage = joint + list(reversed(fem_in))
    tibial_cartilage = list(reversed(joint)) + list(reversed(tib_out))
    tr, tl = tib_out[0], tib_out[-1]
    tibia_bone = [
        (-0.015, -0.30),
        (0.015, -0.30),
        (0.015, -0.08),
        (tr[0], -0.03),
        (tr[0], 0.0),
    ] + tib_out + [(tl[0], -0.03), (-0.015, -0.08)]
    fibula = [(0.040, -0.28), (0.052, -0.28), (0.058, 0.0), (tr[0], 0.0), (tr[0], -0.03), (0.040, -0.06)]
    return {
        "version": 1,
        "name": "Lower limb with cartilage (Czech text, model 2)",
        "description": "Lower limb after the Czech text (CZ 1652-1674): bone E 1.71e10 Pa nu 0.25, "
        "cartilage E 0.492e9 Pa nu 0.1; zero displacement at the ankle ends of tibia and fibula; "
        "bilateral contact (a roller guiding the femur's shaft, and the tied tibiofibular joint); "
        "unilateral (frictionless) contact between the femoral and tibial cartilage; pressure 1e6 Pa "
        "on the femur's top. " + OURS + " Joint arc radius 60 mm, cartilage 3 mm thick, limb 0.7 m.",
        "bodies": [
            {
                "name": "femur",
                "zones": [
                    {"name": "femur", "material": "bone", "polygon": poly(femur_bone)},
                    {"name": "femoral cartilage", "material": "cartilage", "polygon": poly(femoral_cartilage)},
                ],
            },
            {
                "name": "tibia",
                "zones": [
                    {"name": "tibia", "material": "bone", "polygon": poly(tibia_bone)},
                    {"name": "tibial cartilage", "material": "cartilage", "polygon": poly(tibial_cartilage)},
                ],
            },
            {"name": "fibula", "zones": [{"name": "fibula", "material": "bone", "polygon": poly(fibula)}]},
        ],
        "segments": {
            "femur_top": seg("femur", (0.015, 0.40), (-0.015, 0.40)),
            "femur_guide": seg("femur", (-0.015, 0.40), (-0.015, 0.30)),
            "tibia_fixation": seg("tibia", (-0.015, -0.30), (0.015, -0.30)),
            "fibula_fixation": seg("fibula", (0.040, -0.28), (0.052, -0.28)),
            "femoral_surface": path("femur", joint),
            "tibial_surface": path("tibia", joint),
            "fibula_joint": seg("fibula", (tr[0], 0.0), (tr[0], -0.03)),
            "tibia_joint": seg("tibia", (tr[0], -0.03), (tr[0], 0.0)),
        },
        "materials": {"bone": {"E": 1.71e10, "nu": 0.25}, "cartilage": {"E": 0.492e9, "nu": 0.1}},
        "boundary": [
            {"segment": "tibia_fixation", "displacement": [0, 0]},
            {"segment": "fibula_fixation", "displacement": [0, 0]},
            {"segment": "femur_guide", "roller": {}},
            {"segment": "femur_top", "pressure": 1.0e6},
        ],
        "contacts": [
            {"name": "knee joint", "between": ["femoral_surface", "tibial_surface"], "kind": "unilateral", "slip_limit": 0.0},
            {"name": "tibiofibular joint", "between": ["fibula_joint", "tibia_joint"], "kind": "bilateral"},
        ],
        "mesh": {"max_size": 0.012, "refine": [{"segments": ["femoral_surface"], "max_size": 0.002}]},
        "criteria": {
            "regions": [
                {"name": "tibial cartilage", "polygon": box(-0.01, -0.006, 0.01, 0.0), "normal": [0.0, 1.0]},
                {"name": "tibial plateau", "polygon": box(-0.03, -0.03, 0.03, -0.006), "normal_at": [0.0, 0.0]},
            ]
        },
        "uncertain": [
            {"name": "cartilage E", "field": "materials.cartilage.E", "interval": [0.4e9, 0.6e9]},
            {"name": "bone E", "field": "materials.bone.E", "interval": [1.4e10, 2.0e10]},
            {"name": "load", "field": "boundary[3].pressure", "interval": [0.8e6, 1.2e6]},
        ],
        "search": {"criteria": ["phi5", "phi6"], "budget": 40, "seed": 1},
    }


def tibia_marrow():
    """CZ model 3: a tibia whose medullary canal holds marrow tied to the bone."""
    canal_right = [(0.04, 0.0), (0.046, 0.006), (0.048, 0.02), (0.048, 0.20), (0.046, 0.214), (0.04, 0.22)]
    canal_left = [(0.04, 0.22), (0.034, 0.214), (0.032, 0.20), (0.032, 0.02), (0.034, 0.006), (0.04, 0.0)]
    canal = canal_right + canal_left[1:-1]
    outline = [(0.025, -0.1), (0.055, -0.1), (0.055, 0.25), (0.08, 0.34), (0.08, 0.40), (0.0, 0.40), (0.0, 0.34), (0.025, 0.25)]
    return {
        "version": 1,
        "name": "Tibia with bone marrow (Czech text, model 3)",
        "description": "Tibia with bone marrow after the Czech text (CZ 1675-1775): bone E 1.71e10 Pa "
        "nu 0.25, marrow E 2e6 Pa nu 0.49; bottom clamped; 0.2e7 Pa on the plateau; bilateral (tied) "
        "contact between the marrow and the bone. The text's colour bars: bone principal stresses "
        "-2.8494e7 / +1.1893e7 Pa, marrow -2.24e4 / +4.39e3 Pa. Marrow at nu = 0.49 makes P1 lock "
        "(warned): its stresses are an order-of-magnitude statement until a locking-free element "
        "is used. " + OURS + " Section 80 mm x 0.5 m as the text's figure axes, canal 16 mm wide.",
        "bodies": [
            {"name": "bone", "zones": [{"name": "bone", "material": "bone", "polygon": poly(outline), "holes": [poly(canal)]}]},
            {"name": "marrow", "zones": [{"name": "marrow", "material": "marrow", "polygon": poly(canal)}]},
        ],
        "segments": {
            "fixation": seg("bone", (0.025, -0.1), (0.055, -0.1)),
            "plateau": seg("bone", (0.08, 0.40), (0.0, 0.40)),
            "marrow_right": path("marrow", canal_right),
            "canal_right": path("bone", canal_right),
            "marrow_left": path("marrow", canal_left),
            "canal_left": path("bone", canal_left),
        },
        "materials": {"bone": {"E": 1.71e10, "nu": 0.25}, "marrow": {"E": 2.0e6, "nu": 0.49}},
        "boundary": [
            {"segment": "fixation", "displacement": [0, 0]},
            {"segment": "plateau", "pressure": 0.2e7},
        ],
        "contacts": [
            {"name": "marrow right wall", "between": ["marrow_right", "canal_right"], "kind": "bilateral"},
            {"name": "marrow left wall", "between": ["marrow_left", "canal_left"], "kind": "bilateral"},
        ],
        "mesh": {"max_size": 0.006, "refine": [{"segments": ["marrow_right", "marrow_left"], "max_size": 0.004}]},
        "criteria": {
            "regions": [
                {"name": "marrow", "polygon": box(0.034, 0.05, 0.046, 0.17), "normal_at": [0.048, 0.1]},
                {"name": "shaft", "polygon": box(0.048, 0.05, 0.055, 0.17), "normal_at": [0.055, 0.1]},
            ]
        },
        "uncertain": [
            {"name": "marrow E", "field": "materials.marrow.E", "interval": [1.0e6, 3.0e6]},
            {"name": "bone E", "field": "materials.bone.E", "interval": [1.4e10, 2.0e10]},
            {"name": "load", "field": "boundary[1].pressure", "interval": [1.6e6, 2.4e6]},
        ],
        "search": {"criteria": ["phi3", "phi5"], "budget": 40, "seed": 1},
    }


def thermo_contact():
    """FGCS's model: heat from a canister in rock crossed by a fault, Tresca contact on the fault."""
    left = [(0, 0), (9, 0), (11, 20), (0, 20)]
    right = [(9, 0), (20, 0), (20, 20), (11, 20)]
    canister = box(4.5, 9.5, 5.5, 10.5)
    return {
        "version": 1,
        "name": "Thermo-elastic contact on a fault (FGCS 2006)",
        "description": "FGCS 2006's model (Hlavacek, Nedoma et al., FGCS 22 (2006) 468-483, (2.1)-(2.13)): "
        "stationary heat with a heat source W in a canister, zero heat flux on the clamped bottom "
        "(Gamma_u), T = T1 on the loaded sides (Gamma_tau), perfect heat transfer across the fault; "
        "Duhamel-Neumann thermo-elasticity; unilateral contact with Tresca friction on the fault. "
        "Uncertain kappa, W, T1 and beta (FGCS (4.7), (4.10), (4.11), (4.14)) and the slip limit g "
        "(4.15). FGCS section 5 gives no thermal data: the rock (E 5.2e9 Pa nu 0.18 as FGCS section 5; "
        "kappa 3 W/m/K, expansion 8e-6 1/K), the canister (copper), W = 500 W/m3, T1 = 20 C, the "
        "pressures and the geometry (20 m x 20 m, fault from (9, 0) to (11, 20)) are ours. " + OURS,
        "bodies": [
            {
                "name": "left block",
                "zones": [
                    {"name": "left rock", "material": "rock", "polygon": poly(left), "holes": [canister]},
                    {"name": "canister", "material": "canister", "polygon": canister},
                ],
            },
            {"name": "right block", "zones": [{"name": "right rock", "material": "rock", "polygon": poly(right)}]},
        ],
        "segments": {
            "bottom_left": seg("left block", (0, 0), (9, 0)),
            "bottom_right": seg("right block", (9, 0), (20, 0)),
            "top_left": seg("left block", (11, 20), (0, 20)),
            "top_right": seg("right block", (20, 20), (11, 20)),
            "side_left": seg("left block", (0, 20), (0, 0)),
            "side_right": seg("right block", (20, 0), (20, 20)),
            "fault_left": seg("left block", (9, 0), (11, 20)),
            "fault_right": seg("right block", (9, 0), (11, 20)),
        },
        "materials": {
            "rock": {"E": 5.2e9, "nu": 0.18, "conductivity": 3.0, "heat_source": 0.0, "expansion": 8e-6},
            "canister": {"E": 1.1e11, "nu": 0.34, "conductivity": 390.0, "heat_source": 500.0, "expansion": 1.7e-5},
        },
        "thermal": {"reference_temperature": 20.0},
        "boundary": [
            {"segment": "bottom_left", "displacement": [0, 0]},
            {"segment": "bottom_right", "displacement": [0, 0]},
            {"name": "top left", "segment": "top_left", "pressure": 5.0e6},
            {"name": "top right", "segment": "top_right", "pressure": 5.0e6},
            {"name": "side left", "segment": "side_left", "pressure": 5.0e6},
            {"name": "side right", "segment": "side_right", "pressure": 5.0e6},
            {"name": "T1 top left", "segment": "top_left", "temperature": 20.0},
            {"name": "T1 top right", "segment": "top_right", "temperature": 20.0},
            {"name": "T1 side left", "segment": "side_left", "temperature": 20.0},
            {"name": "T1 side right", "segment": "side_right", "temperature": 20.0},
        ],
        "contacts": [{"name": "fault", "between": ["fault_left", "fault_right"], "kind": "unilateral", "slip_limit": 1.0e6}],
        "mesh": {"max_size": 1.0, "refine": [{"segments": ["fault_left"], "max_size": 0.5}]},
        "criteria": {
            "regions": [
                {"name": "canister", "polygon": box(4.6, 9.6, 5.4, 10.4), "normal": [1.0, 0.0]},
                {"name": "fault, left side", "polygon": [[9.6, 6], [10.6, 6], [10.8, 8], [9.8, 8]], "normal": [0.995037, -0.099504]},
            ]
        },
        "uncertain": [
            {"name": "kappa", "field": "materials.rock.conductivity", "interval": [2.5, 3.5]},
            {"name": "W", "field": "materials.canister.heat_source", "interval": [400.0, 600.0]},
            {
                "name": "T1",
                "field": "boundary[T1 top left].temperature",
                "interval": [15.0, 25.0],
                "drives": [
                    {"field": f"boundary[T1 {side}].temperature", "factor": 1.0}
                    for side in ("top right", "side left", "side right")
                ],
            },
            {"name": "beta", "field": "materials.rock.expansion", "interval": [6e-6, 1e-5]},
            {"name": "g", "field": "contacts[fault].slip_limit", "interval": [0.5e6, 1.5e6]},
        ],
        "search": {"criteria": ["phi1", "phi6"], "budget": 60, "seed": 1},
    }


def knee_sagittal():
    """MCS 2007 Fig. 1b: the sagittal section of the total knee replacement."""
    face_deg, half = 6.0, 0.02
    y_top = 0.072
    depth = half * math.tan(math.radians(face_deg))
    post, low, ant = (-half, y_top), (0.0, y_top - depth), (half, y_top)
    rise = 0.006 * math.tan(math.radians(face_deg))
    tibia = [(-0.015, 0.0), (0.015, 0.0), (0.015, 0.035), (0.025, 0.045), (0.025, 0.055), (-0.025, 0.055), (-0.025, 0.045), (-0.015, 0.035)]
    tray = box(-0.025, 0.055, 0.025, 0.060)
    insert = [(-0.025, 0.060), (0.025, 0.060), (0.025, y_top), ant, low, post, (-0.025, y_top)]
    component = [post, low, ant, (half, 0.080), (-half, 0.080)]
    femur = [(-half, 0.080), (half, 0.080), (half, 0.100), (0.015, 0.110), (0.015, 0.150), (-0.015, 0.150), (-0.015, 0.110), (-half, 0.100)]
    faces = [("posterior", post, low), ("anterior", low, ant)]
    segments = {
        "tibia_fixation": seg("tibia", (-0.015, 0.0), (0.015, 0.0)),
        "femur_top": seg("femur", (0.015, 0.150), (-0.015, 0.150)),
        "femur_guide": seg("femur", (-0.015, 0.150), (-0.015, 0.130)),
    }
    contacts = []
    for name, a, b in faces:
        segments[f"femur_{name}"] = seg("femur", a, b)
        segments[f"insert_{name}"] = seg("tibia", a, b)
        mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
        contacts.append(
            {
                "name": f"{name} face",
                "between": [f"femur_{name}", f"insert_{name}"],
                "kind": "unilateral",
                "friction_coefficient": 0.07,
                "initial_gap": {"parabola": {"radius": KNEE_RADIUS / 2, "touch_at": r(mid)}},
            }
        )
    return {
        "version": 1,
        "name": "Knee replacement, sagittal section (MCS 2007)",
        "description": "Total knee replacement, sagittal section, after Danek et al. MCS 2007 (Fig. 1b): "
        "bone E 1.71e10 Pa nu 0.25, Ti6Al4V tray 1.15e11/0.3, UHMWPE insert 3.4e8/0.4, CoCrMo femoral "
        "component 2.08e11/0.3; 2.15e6 Pa on the femur's top; tibia clamped; Coulomb friction on the "
        "condyle (F not given: ours 0.07, uncertain in [0.04, 0.10]). " + OURS + " Insert dished by two "
        "faces at 6 deg (posterior, anterior), condyle radius 50 mm in the sagittal plane (parabolic gap), "
        "the femur's shaft guided horizontally at its top by a roller (the other structures of the joint).",
        "bodies": [
            {
                "name": "tibia",
                "zones": [
                    {"name": "tibia", "material": "bone", "polygon": poly(tibia)},
                    {"name": "tray", "material": "ti6al4v", "polygon": tray},
                    {"name": "insert", "material": "uhmwpe", "polygon": poly(insert)},
                ],
            },
            {
                "name": "femur",
                "zones": [
                    {"name": "component", "material": "cocrmo", "polygon": poly(component)},
                    {"name": "femur", "material": "bone", "polygon": poly(femur)},
                ],
            },
        ],
        "segments": segments,
        "materials": KNEE_MATERIALS,
        "boundary": [
            {"segment": "tibia_fixation", "displacement": [0, 0]},
            {"segment": "femur_guide", "roller": {}},
            {"segment": "femur_top", "pressure": KNEE_LOAD},
        ],
        "contacts": contacts,
        "mesh": {"max_size": 0.003, "refine": [{"segments": ["femur_posterior", "femur_anterior"], "max_size": 0.0008}]},
        "criteria": {
            "regions": [
                {
                    "name": "insert under the condyle",
                    "polygon": poly([(-0.006, 0.066), (0.006, 0.066), (0.006, low[1] + rise), low, (-0.006, low[1] + rise)]),
                    "normal": [0.0, 1.0],
                },
                {"name": "femoral bone above the cut", "polygon": box(-0.015, 0.080, 0.015, 0.085), "normal": [0.0, -1.0]},
            ]
        },
        "uncertain": [
            {"name": "insert E", "field": "materials.uhmwpe.E", "interval": [2.5e8, 4.5e8]},
            {"name": "load", "field": "boundary[2].pressure", "interval": [1.8e6, 2.5e6]},
            {"name": "F posterior", "field": "contacts[posterior face].friction_coefficient", "interval": [0.04, 0.10]},
            {"name": "F anterior", "field": "contacts[anterior face].friction_coefficient", "interval": [0.04, 0.10]},
        ],
        "search": {"criteria": ["phi5", "phi6"], "budget": 60, "seed": 1},
    }


def d03():
    """D03 section 5: three regions, two unilateral zones, a bilateral boundary."""
    base = [(0, 0), (1.2, 0), (1.2, 0.3), (1.1, 0.3), (0.65, 0.3), (0.55, 0.3), (0.1, 0.3), (0, 0.3)]
    return {
        "version": 1,
        "name": "D03 model problem",
        "description": "The model problem of Danek, MCS 61 (2003) 359-373, section 5: three regions E 1e10 Pa "
        "nu 0.3; zero displacement on the base's bottom; pressure 0.18e7 Pa on the top; bilateral "
        "contact boundary (rollers: bilateral contact with the rigid foundation) on the blocks' outer "
        "sides; two unilateral (frictionless) contact boundaries between the blocks and the base. D03: "
        "8 subdomains, 1748 nodes, 3040 elements, 28 unilateral contact conditions; 9 PCG1, 17 successive "
        "approximations, 38 PCG2 iterations. " + OURS + " The base 1.2 m x 0.3 m with two 0.45 m x 0.5 m "
        "blocks; the pressure (one datum) acts on both blocks' tops and the bilateral boundary is two rollers.",
        "bodies": [
            {"name": "base", "zones": [{"name": "base", "material": "steel", "polygon": poly(base)}]},
            {"name": "left block", "zones": [{"name": "left block", "material": "steel", "polygon": box(0.1, 0.3, 0.55, 0.8)}]},
            {"name": "right block", "zones": [{"name": "right block", "material": "steel", "polygon": box(0.65, 0.3, 1.1, 0.8)}]},
        ],
        "segments": {
            "base_bottom": seg("base", (0, 0), (1.2, 0)),
            "left_top": seg("left block", (0.55, 0.8), (0.1, 0.8)),
            "right_top": seg("right block", (1.1, 0.8), (0.65, 0.8)),
            "left_side": seg("left block", (0.1, 0.8), (0.1, 0.3)),
            "right_side": seg("right block", (1.1, 0.3), (1.1, 0.8)),
            "left_bottom": seg("left block", (0.1, 0.3), (0.55, 0.3)),
            "base_left": seg("base", (0.1, 0.3), (0.55, 0.3)),
            "right_bottom": seg("right block", (0.65, 0.3), (1.1, 0.3)),
            "base_right": seg("base", (0.65, 0.3), (1.1, 0.3)),
        },
        "materials": {"steel": {"E": 1.0e10, "nu": 0.3}},
        "boundary": [
            {"segment": "base_bottom", "displacement": [0, 0]},
            {"segment": "left_top", "pressure": 1.8e6},
            {"segment": "right_top", "pressure": 1.8e6},
            {"segment": "left_side", "roller": {}},
            {"segment": "right_side", "roller": {}},
        ],
        "contacts": [
            {"name": "left zone", "between": ["left_bottom", "base_left"], "kind": "unilateral", "slip_limit": 0.0},
            {"name": "right zone", "between": ["right_bottom", "base_right"], "kind": "unilateral", "slip_limit": 0.0},
        ],
        "mesh": {"max_size": 0.05},
        "criteria": {
            "regions": [
                {"name": "left block's foot", "polygon": box(0.1, 0.3, 0.55, 0.35), "normal": [0.0, 1.0]},
                {"name": "right block's top", "polygon": box(0.65, 0.75, 1.1, 0.8), "normal_at": [0.875, 0.8]},
            ]
        },
        "uncertain": [
            {"name": "E", "field": "materials.steel.E", "interval": [0.9e10, 1.1e10]},
            {
                "name": "pressure",
                "field": "boundary[1].pressure",
                "interval": [1.6e6, 2.0e6],
                "drives": [{"field": "boundary[2].pressure", "factor": 1.0}],
            },
        ],
        "search": {"criteria": ["phi3", "phi6"], "budget": 40, "seed": 1},
    }


def main():
    out_dir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes")
    scenes = {
        "hip-replacement": hip(),
        "lower-limb-cartilage": lower_limb(),
        "tibia-marrow": tibia_marrow(),
        "thermo-contact-fault": thermo_contact(),
        "knee-sagittal": knee_sagittal(),
        "d03-model-problem": d03(),
    }
    for name, value in scenes.items():
        with open(os.path.join(out_dir, f"{name}.json"), "w") as f:
            json.dump(value, f, indent=2)
            f.write("\n")
        print(f"scenes/{name}.json")


if __name__ == "__main__":
    main()
