"""Reads what `cairn_base --json` printed (answers and events, one JSON document after another, with any
non-JSON line skipped) for the fleet benches (bench/real_scan_fleet.sh, bench/team_explore_load.sh)."""
import json


def read_answers(path):
    """Every JSON document in the file at `path`, in order."""
    text = open(path, errors="replace").read()
    decoder, i, answers = json.JSONDecoder(), 0, []
    while i < len(text):
        if text[i].isspace():
            i += 1
            continue
        try:
            obj, i = decoder.raw_decode(text, i)
            answers.append(obj)
        except ValueError:
            i = text.find("\n", i) + 1 or len(text)
    return answers


def explorations(answers):
    """Per robot: the explored m² of each `status` answer, and the last exploration state and reason."""
    explored, states = {}, {}
    for a in answers:
        r = a.get("robot") or a.get("robot_id")
        ex = a.get("exploration")
        if r and isinstance(ex, dict) and not a.get("event"):
            explored.setdefault(r, []).append(ex.get("explored_m2", 0.0))
            states[r] = (ex.get("state"), ex.get("reason", ""))
    return explored, states


def event_counts(answers):
    """The events' kinds, counted."""
    kinds = {}
    for a in answers:
        if a.get("event"):
            kinds[a["event"]] = kinds.get(a["event"], 0) + 1
    return kinds
