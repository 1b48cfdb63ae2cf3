# Prints the --set override of the sliding tool of perf/adaptivity_report.cpp (moving_tool), 12 s:
#   build/perf/frame_probe ... --set "$(python3 slide_keyframes.py)"
import json, math

z = lambda x: 0.04 * math.sqrt(1 - ((x - 0.025) / 0.075) ** 2) + 0.015 - 0.01
k = [{"time": 0.0, "position": [0.03, 0.0, 0.058]}, {"time": 0.4, "position": [0.03, 0.0, z(0.03)]}]
t, x, right = 0.4, 0.03, True
while t < 12:
    to = 0.06 if right else 0.0
    t += 2.0 * abs(to - x) / 0.06
    x, right = to, not right
    k.append({"time": t, "position": [x, 0.0, z(x)]})
print("tools[0].path.keyframes=" + json.dumps(k, separators=(",", ":")))
