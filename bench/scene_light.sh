# shellcheck shell=bash
# Sourced by bench/shadows.sh and bench/ray.sh.
# light_of SCENE.ini: a point light to the side of the scene's target, as far from it
# as the eye: target + r (0.8 right + 0.6 up), r = |eye - target|, in the camera's frame
# (right = fwd x up, up re-orthogonalised), as ray_camera_init builds it.  Printed as
# "X Y Z" for ivoct render --light.
light_of() {
    /usr/bin/python3 - "$1" <<'EOF'
import configparser, math, sys
c = configparser.ConfigParser(inline_comment_prefixes=(";", "#"), strict=False)
c.read(sys.argv[1])
v = lambda k, d: [float(x) for x in c.get("camera", k, fallback=d).split()]
eye, target, up = v("eye", ""), v("target", "0 0 0"), v("up", "0 0 1")
sub = lambda a, b: [a[i] - b[i] for i in range(3)]
cross = lambda a, b: [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
unit = lambda a: [x / math.sqrt(sum(y * y for y in a)) for x in a]
fwd = unit(sub(target, eye)); right = unit(cross(fwd, up)); vup = cross(right, fwd)
r = math.sqrt(sum(x * x for x in sub(eye, target)))
print(" ".join("%.6g" % (target[i] + r * (0.8 * right[i] + 0.6 * vup[i])) for i in range(3)))
EOF
}
