#!/usr/bin/env bash
# Renders `swarmfl view` in headless Chromium and checks the page against the log:
#   1. the page runs without script errors (it writes its state into <pre id="status">, which
#      --dump-dom reads);
#   2. opened at a block (URL hash #block=H), it shows the log's state at that block: every
#      robot's position, tokens, behaviour and forager state equal what
#      `swarmfl inspect LOG --block H --json` prints; each behaviour has a colour of its own;
#      a swarm with foragers shows the nest and the food sources (under Flow-FL's rule the nest
#      strip and the items on the floor at that moment, which with the items carried make all);
#   3. a screenshot at that moment is taken (SCREENSHOT=path keeps it, e.g. docs/view.png);
#   4. the layout (scripts/page_check.py layout): no horizontal scroll at 1024x768, the reorg
#      text above the fold at 1400x900 (SCREENSHOT_1024=path keeps the 1024 px screenshot);
#   5. the live view (scripts/page_check.py live): `swarmfl run --live` in headless Chromium,
#      frames advancing while the run goes, Ctrl-C stopping run and server, and a page open at
#      the end saying the run ended (LIVE_SCREENSHOT=path keeps a screenshot of it running).
# Usage: scripts/view_check.sh [LOG]   (default: a fresh smoke run of a mixed swarm, a third of
#   each behaviour; RUN_PRESET=name replaces its preset and RUN_SET="key=value ..." its overrides;
#   VIEW_ONLY=1 stops after step 3, the checks that depend on the log; SWARMFL=path/to/swarmfl)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${SWARMFL:-target/release/swarmfl}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
log=${1:-}
if [ -z "$log" ]; then
  sets=()
  for kv in ${RUN_SET-world.behaviour=mixed}; do sets+=(--set "$kv"); done
  "$bin" run --preset "${RUN_PRESET:-smoke}" --seed 3 "${sets[@]}" --out "$work/run" --quiet
  log=$work/run/run.swlog
fi
"$bin" view "$log" --out "$work/run.html"
last=$("$bin" inspect "$log" --block 0 --json --no-index | python3 -c 'import json,sys; print(json.load(sys.stdin)["last_height"])')
height=$(( last * 2 / 3 ))
"$bin" inspect "$log" --block "$height" --json --no-index > "$work/inspect.json"

chrome=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
if [ -z "$chrome" ]; then
  echo "view_check: no chromium found (apt-get install -y chromium)" >&2
  exit 1
fi
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run
  --disable-background-networking --disable-component-update --disable-sync
  --user-data-dir="$work/profile")
url="file://$(cd "$work" && pwd)/run.html#block=$height"
"$chrome" "${flags[@]}" --virtual-time-budget=5000 --dump-dom "$url" > "$work/dom.html" 2> "$work/chrome.log"
"$chrome" "${flags[@]}" --window-size=1240,900 --virtual-time-budget=5000 \
  --screenshot="$work/view.png" "$url" >> "$work/chrome.log" 2>&1

python3 - "$work/dom.html" "$work/inspect.json" "$height" <<'EOF'
import html, json, re, sys
dom = open(sys.argv[1]).read()
m = re.search(r'<pre id="status">(.*?)</pre>', dom, re.S)
if not m:
    sys.exit("view_check: the page has no status element: it did not render")
status = json.loads(html.unescape(m.group(1)))
if status.get("loading"):
    sys.exit("view_check: the page's script did not run (status still 'loading')")
if not status["ok"] or status["errors"]:
    sys.exit(f"view_check: script errors: {status['errors']}")
want = json.load(open(sys.argv[2]))
height = int(sys.argv[3])
if status["height"] != height:
    sys.exit(f"view_check: page shows block {status['height']}, asked for {height}")
world = {r["robot"]: r for r in want["world"]["robots"]}
tokens = {b["robot"]: b["tokens"] for b in want["contract"]["balances"]}
bad = []
for r in status["robots"]:
    w = world[r["id"]]
    if abs(r["x"] - w["x"]) > 0.0006 or abs(r["y"] - w["y"]) > 0.0006:
        bad.append(f"robot {r['id']} at ({r['x']}, {r['y']}), log ({w['x']:.4f}, {w['y']:.4f})")
    if abs(r["tokens"] - tokens[r["id"]]) > 0.0006:
        bad.append(f"robot {r['id']} tokens {r['tokens']}, log {tokens[r['id']]}")
    if r["behaviour"] != w["behaviour"] or r.get("forager") != w.get("forager"):
        bad.append(f"robot {r['id']} {r['behaviour']}/{r.get('forager')}, "
                   f"log {w['behaviour']}/{w.get('forager')}")
colours = {}
for r in status["robots"]:
    colours.setdefault(r["behaviour"], set()).add(r["colour"])
# With more than one behaviour, robots are coloured by behaviour alone (Byzantine ones ringed).
if len(colours) > 1 and (any(len(c) != 1 for c in colours.values())
                         or len(set().union(*colours.values())) != len(colours)):
    bad.append(f"behaviours do not each have a colour of their own: {colours}")
flowfl = status.get("nest_strip") is not None
if any(r["behaviour"] == "foraging" for r in status["robots"]) and not flowfl and \
        (not status["nest"] or not status["food"]):
    bad.append("foragers but no nest or food sources on the page")
# Flow-FL's foraging (world.foraging.rule = "flowfl"): the nest strip and the items of the frame
# shown; every item is on the floor east of the strip or carried, as all were at the start.
if any(r["behaviour"] == "foraging" for r in status["robots"]) and "items" in status:
    items, carried = status["items"], sum(1 for r in status["robots"] if r.get("carrying"))
    if not flowfl or not items:
        bad.append(f"flowfl foragers but nest strip {status.get('nest_strip')}, items {items}")
    elif len(items) + carried != status["items_at_start"]:
        bad.append(f"{len(items)} items on the floor and {carried} carried, "
                   f"{status['items_at_start']} at the start")
    elif any(x <= status["nest_strip"] for x, _ in items):
        bad.append(f"an item in the nest strip: {items}")
if bad:
    sys.exit("view_check: the page differs from the log:\n  " + "\n  ".join(bad))
print(f"view_check: block {height} at t = {status['time_s']} s: {len(status['robots'])} robots' "
      f"positions, tokens and behaviours ({', '.join(sorted(colours))}) match `swarmfl inspect`; "
      + (f"nest strip and {len(status['items'])} items on the floor ({status['items_at_start']} with "
         f"those carried); " if "items" in status else "")
      + "no script errors")
EOF
test -s "$work/view.png" || { echo "view_check: no screenshot" >&2; cat "$work/chrome.log" >&2; exit 1; }
if [ -n "${SCREENSHOT:-}" ]; then
  cp "$work/view.png" "$SCREENSHOT"
  echo "view_check: screenshot in $SCREENSHOT"
fi
if [ "${VIEW_ONLY:-0}" = 1 ]; then exit 0; fi
python3 scripts/page_check.py layout "$url" ${SCREENSHOT_1024:+--shot "$SCREENSHOT_1024"}
python3 scripts/page_check.py live "$bin" ${LIVE_SCREENSHOT:+--shot "$LIVE_SCREENSHOT"}
