#!/usr/bin/env python3
"""Generates a retrieval query set from a simulated city's ground truth (issue 29).

A second method beside the hand-written sets in ingest/eval/data: the queries come from the
simulator's records (ground_truth/objects.json): what each object is for (its `purpose`), which
objects stand close together, and the nouns and colours of its attributes, put into sentences by
templates chosen with a seeded RNG. The rules in llm_tools were never read for it. Half of the
queries (by a hash of the text) go to a tuning file, the rest to a held-out file that is only
ever run, never tuned on.

    python3 scripts/retrieval_queries_from_truth.py --sim out/sim --out DIR [--seed 0] [--per-type 20]

writes DIR/retrieval_generated_tune.jsonl and DIR/retrieval_generated_heldout.jsonl in the
format `opengraph eval retrieval --queries` reads.
"""

import argparse
import hashlib
import json
import math
import random
import sys
from pathlib import Path

# things a person looks for in a street; the rest (trunks, poles, buildings, people, cars) are
# too many or too alike to name one
FURNITURE = [
    "bench",
    "bus stop shelter",
    "fire hydrant",
    "trash can",
    "mailbox",
    "bicycle",
    "motorcycle",
    "traffic light",
    "street lamp",
    "billboard",
    "playground",
    "parked trailer",
]

NAMED = [
    "{Colour}{noun}, please",
    "I'm trying to spot a {colour}{noun}",
    "any {colour}{noun} around?",
    "point me to a {colour}{noun}",
    "which way to the {colour}{noun}",
]

RELATIONAL = [
    "the {t} right beside a {a}",
    "a {t} a few steps from the {a}",
    "the {t} that stands close to a {a}",
    "I want the {t} next to the {a}",
    "that {t} by the {a}",
    "a {t} with a {a} nearby",
]

# a purpose that names a thing ("a place to sit and rest") or says what it does ("gives shade")
FUNCTIONAL_THING = [
    "I need {p}",
    "is there {p} somewhere here?",
    "can you find me {p}",
    "looking for {p}",
]
FUNCTIONAL_DOES = [
    "something that {p}",
    "what around here {p}?",
    "show me a thing that {p}",
    "find whatever {p}",
]


def gap(a, b):
    """Ground-plane distance between two boxes' footprints, approximated by their centres less
    half their mean extents (x and z are the ground; y points down)."""
    ca, cb = a["box"]["center"], b["box"]["center"]
    d = math.hypot(ca[0] - cb[0], ca[2] - cb[2])
    ra = 0.25 * (a["box"]["size"][0] + a["box"]["size"][2])
    rb = 0.25 * (b["box"]["size"][0] + b["box"]["size"][2])
    return max(0.0, d - ra - rb)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sim", required=True, type=Path)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--per-type", type=int, default=20)
    args = ap.parse_args()
    path = args.sim / "ground_truth" / "objects.json"
    try:
        objects = json.loads(path.read_text())["objects"]
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"{path}: not a simulator's ground truth ({e})")
    rng = random.Random(args.seed)
    furniture = [o for o in objects if o["class"] in FURNITURE]
    queries = []

    # named: a kind by one of its nouns, with its colour half of the time
    for o in rng.sample(furniture, min(args.per_type, len(furniture))):
        colour = o["attributes"].get("colour") if rng.random() < 0.5 else None
        tpl = rng.choice(NAMED)
        c = f"{colour} " if colour else ""
        text = tpl.format(colour=c, Colour=c.capitalize() if c else "A ", noun=o["attributes"]["noun"])
        q = {"text": text, "type": "named", "target": [o["class"]]}
        if colour:
            q["colour"] = colour.split()[-1]
        queries.append(q)

    # relational: a piece of furniture and another kind of thing within 3 m of it
    pairs = [
        (t, a)
        for t in furniture
        for a in furniture
        if a["class"] != t["class"] and gap(t, a) <= 3.0
    ]
    pairs.sort(key=lambda p: (p[0]["id"], p[1]["id"]))
    seen = set()
    rng.shuffle(pairs)
    for t, a in pairs:
        key = (t["class"], a["class"])
        if key in seen:
            continue
        seen.add(key)
        text = rng.choice(RELATIONAL).format(t=t["attributes"]["noun"], a=a["attributes"]["noun"])
        queries.append(
            {
                "text": text,
                "type": "relational",
                "target": [t["class"]],
                "near": {"class": [a["class"]], "within_m": 6},
            }
        )
        if sum(q["type"] == "relational" for q in queries) >= args.per_type:
            break

    # functional: each kind by what it is for, in two wordings
    kinds = sorted({o["class"]: o["purpose"] for o in objects if o["class"] != "person"}.items())
    func = []
    for cls, purpose in kinds:
        thing = purpose.startswith(("a ", "an "))
        tpls = FUNCTIONAL_THING if thing else FUNCTIONAL_DOES
        for tpl in rng.sample(tpls, 2):
            func.append({"text": tpl.format(p=purpose), "type": "functional", "target": [cls]})
    rng.shuffle(func)
    queries.extend(func[: args.per_type])

    args.out.mkdir(parents=True, exist_ok=True)
    try:
        sim = json.loads((args.sim / "sim.json").read_text())
        city = f"opengraph sim --size {sim['size']} --seed {sim['seed']}"
    except (OSError, ValueError, KeyError):
        city = str(args.sim)
    head = (
        f"# Generated by scripts/retrieval_queries_from_truth.py --seed {args.seed} from the ground "
        f"truth of `{city}` (purposes, neighbours, nouns); {{}}\n"
    )
    # one query per text
    unique = {}
    for q in queries:
        unique.setdefault(q["text"], q)
    queries = list(unique.values())
    files = {
        "tune": (args.out / "retrieval_generated_tune.jsonl", "the half that may be tuned on"),
        "heldout": (args.out / "retrieval_generated_heldout.jsonl", "held out: run, never tuned on"),
    }
    split = {"tune": [], "heldout": []}
    for q in queries:
        h = hashlib.sha256(q["text"].encode()).digest()[0]
        split["tune" if h % 2 == 0 else "heldout"].append(q)
    for name, (p, what) in files.items():
        with open(p, "w") as f:
            f.write(head.format(what))
            for q in split[name]:
                f.write(json.dumps(q) + "\n")
        counts = {t: sum(q["type"] == t for q in split[name]) for t in ("named", "relational", "functional")}
        print(f"{p}: {len(split[name])} queries {counts}")


if __name__ == "__main__":
    main()
