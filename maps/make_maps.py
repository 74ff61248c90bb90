#!/usr/bin/env python3
"""Writes the bundled test maps of this folder (run from anywhere: `python3 maps/make_maps.py`).

Rooms are hollow shells of 16-unit box brushes around an air box; doorways and corridors are air
boxes carved out of every wall brush (box minus box gives at most six boxes). Every side's three
points are ordered so that its plane normal, (p0 - p1) x (p2 - p1), points out of the brush.
"""
import os

T = 16  # wall thickness
HERE = os.path.dirname(os.path.abspath(__file__))


def fmt(v):
    return str(int(v)) if float(v).is_integer() else repr(float(v))


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


class Brush:
    """Convex brush: a list of (p0, p1, p2, texture) oriented to face away from `inside`."""

    def __init__(self, planes, inside):
        self.sides = []
        for p0, p1, p2, tex in planes:
            n = cross(sub(p0, p1), sub(p2, p1))
            if dot(n, sub(inside, p1)) > 0:
                p0, p2 = p2, p0
            self.sides.append((p0, p1, p2, tex))

    def text(self, valve=False):
        out = ["{"]
        for p0, p1, p2, tex in self.sides:
            pts = " ".join("( %s )" % " ".join(fmt(c) for c in p) for p in (p0, p1, p2))
            if valve:
                n = cross(sub(p0, p1), sub(p2, p1))
                axis = max(range(3), key=lambda i: abs(n[i]))
                u, v = [[0, 1, 0, 0], [0, 0, -1, 0]] if axis == 0 else (
                    [[1, 0, 0, 0], [0, 0, -1, 0]] if axis == 1 else [[1, 0, 0, 0], [0, -1, 0, 0]])
                tail = "[ %s ] [ %s ] 0 1 1" % (" ".join(map(str, u)), " ".join(map(str, v)))
            else:
                tail = "0 0 0 1 1"
            out.append("%s %s %s" % (pts, tex, tail))
        out.append("}")
        return "\n".join(out)


def box(lo, hi, tex="wall"):
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    centre = [(lo[i] + hi[i]) / 2 for i in range(3)]
    planes = [
        ([x0, y0, z0], [x0, y1, z0], [x0, y0, z1], tex),
        ([x1, y0, z0], [x1, y0, z1], [x1, y1, z0], tex),
        ([x0, y0, z0], [x0, y0, z1], [x1, y0, z0], tex),
        ([x0, y1, z0], [x1, y1, z0], [x0, y1, z1], tex),
        ([x0, y0, z0], [x1, y0, z0], [x0, y1, z0], tex),
        ([x0, y0, z1], [x0, y1, z1], [x1, y0, z1], tex),
    ]
    return Brush(planes, centre)


def prism(poly, z0, z1, tex="wall"):
    """A vertical prism over a convex XY polygon."""
    cx = sum(p[0] for p in poly) / len(poly)
    cy = sum(p[1] for p in poly) / len(poly)
    inside = [cx, cy, (z0 + z1) / 2]
    planes = []
    for i, a in enumerate(poly):
        b = poly[(i + 1) % len(poly)]
        planes.append(([a[0], a[1], z0], [b[0], b[1], z0], [a[0], a[1], z1], tex))
    a, b, c = poly[0], poly[1], poly[2]
    planes.append(([a[0], a[1], z0], [b[0], b[1], z0], [c[0], c[1], z0], tex))
    planes.append(([a[0], a[1], z1], [b[0], b[1], z1], [c[0], c[1], z1], tex))
    return Brush(planes, inside)


def box_minus(a, b):
    """Boxes covering a - b (a, b = (lo, hi))."""
    lo, hi = list(a[0]), list(a[1])
    blo, bhi = b
    if any(bhi[i] <= lo[i] or blo[i] >= hi[i] for i in range(3)):
        return [a]
    out = []
    for i in range(3):
        if blo[i] > lo[i]:
            nhi = list(hi)
            nhi[i] = blo[i]
            out.append((list(lo), nhi))
            lo[i] = blo[i]
        if bhi[i] < hi[i]:
            nlo = list(lo)
            nlo[i] = bhi[i]
            out.append((nlo, list(hi)))
            hi[i] = bhi[i]
    return out


def shell(lo, hi, t=T):
    """Six slabs enclosing the air box lo..hi."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        ([x0 - t, y0 - t, z0 - t], [x1 + t, y1 + t, z0]),
        ([x0 - t, y0 - t, z1], [x1 + t, y1 + t, z1 + t]),
        ([x0 - t, y0 - t, z0], [x0, y1 + t, z1]),
        ([x1, y0 - t, z0], [x1 + t, y1 + t, z1]),
        ([x0, y0 - t, z0], [x1, y0, z1]),
        ([x0, y1, z0], [x1, y1 + t, z1]),
    ]


def carve(solids, airs):
    for air in airs:
        solids = [piece for s in solids for piece in box_minus(s, air)]
    return solids


def rooms(areas, carves=()):
    """Box brushes for hollow areas (air boxes) joined by carved openings."""
    solids = [s for lo, hi in areas for s in shell(lo, hi)]
    solids = carve(solids, list(areas) + list(carves))
    return [box(lo, hi) for lo, hi in solids]


def entity(props, brushes=(), valve=False):
    lines = ["{"] + ['"%s" "%s"' % kv for kv in props] + [b.text(valve) for b in brushes] + ["}"]
    return "\n".join(lines)


def write(name, header, world, entities=(), valve=False, extra_world=()):
    props = [("classname", "worldspawn")] + list(extra_world)
    parts = [header.rstrip()] + [entity(props, world, valve)]
    parts += [entity(p, b, valve) for p, b in entities]
    with open(os.path.join(HERE, name), "w") as f:
        f.write("\n".join(parts) + "\n")


def point(cls, origin, **extra):
    return ([("classname", cls), ("origin", " ".join(fmt(c) for c in origin))] + list(extra.items()), [])


def marker(name, origin):
    """An info_null naming a spot that tests refer to."""
    return point("info_null", origin, targetname=name)


def main():
    # room.map: the smallest sealed room.
    write("room.map", "// The smallest sealed room: one 256x256x128 box of six 16-unit walls.",
          rooms([([0, 0, 0], [256, 256, 128])]),
          [point("info_player_start", [128, 128, 24])])

    # two_rooms.map: rooms A and B joined by a straight corridor.
    a = ([0, 0, 0], [256, 256, 128])
    corr = ([272, 96, 0], [496, 160, 96])
    b = ([512, 0, 0], [768, 256, 128])
    door = ([240, 96, 0], [528, 160, 96])
    write("two_rooms.map", "// Two rooms joined by a straight corridor; A and B see each other.",
          rooms([a, corr, b], [door]),
          [point("info_player_start", [128, 128, 24]), marker("room_a", [128, 128, 64]),
           marker("corridor", [384, 128, 48]), marker("room_b", [640, 128, 64])])

    # lbend.map: A -> east corridor -> north corridor -> C; C is hidden from A.
    a = ([0, 0, 0], [256, 256, 128])
    east = ([272, 96, 0], [640, 160, 96])
    north = ([576, 176, 0], [640, 496, 96])
    c = ([480, 512, 0], [736, 768, 128])
    openings = [([240, 96, 0], [288, 160, 96]), ([576, 144, 0], [640, 192, 96]),
                ([576, 480, 0], [640, 528, 96])]
    write("lbend.map", "// An L bend: room A sees the east corridor but not room C around the corner.",
          rooms([a, east, north, c], openings),
          [point("info_player_start", [128, 128, 24]), marker("room_a", [128, 128, 64]),
           marker("corridor_east", [448, 128, 48]), marker("corridor_north", [608, 336, 48]),
           marker("room_c", [608, 640, 64])])

    # leak.map: a 32x32 hole through the east wall to the void.
    write("leak.map", "// A room with a 32x32 hole in its east wall: must be reported as a leak.",
          [box(lo, hi) for lo, hi in carve(shell([0, 0, 0], [256, 256, 128]),
                                           [([0, 0, 0], [256, 256, 128]), ([250, 112, 32], [280, 144, 64])])],
          [point("info_player_start", [128, 128, 24])])

    # angled.map: non-axial brushes inside a sealed room.
    diamond = prism([[384, 96], [448, 160], [384, 224], [320, 160]], 0, 192)
    octagon = prism([[128, 432], [160, 400], [208, 400], [240, 432], [240, 480], [208, 512],
                     [160, 512], [128, 480]], 0, 192)
    ramp = Brush([([64, 64, 0], [64, 192, 0], [64, 64, 1], "wall"),            # west (low end)
                  ([256, 64, 0], [256, 192, 0], [256, 64, 1], "wall"),         # east (high end)
                  ([64, 64, 0], [256, 64, 0], [64, 64, 1], "wall"),            # south
                  ([64, 192, 0], [256, 192, 0], [64, 192, 1], "wall"),         # north
                  ([64, 64, 0], [256, 64, 0], [64, 192, 0], "floor"),          # bottom
                  ([64, 64, 8], [256, 64, 72], [64, 192, 8], "floor")],        # slope
                 [192, 128, 20])
    write("angled.map", "// Non-axial brushes (a diamond and an octagon pillar, a ramp) in a sealed room.",
          rooms([([0, 0, 0], [576, 576, 192])]) + [diamond, octagon, ramp],
          [point("info_player_start", [480, 480, 24])])

    # stairs_pillars.map: a hall with pillars and a staircase up to a balcony.
    hall = ([0, 0, 0], [768, 512, 256])
    world = rooms([hall])
    for i in range(8):
        world.append(box([384 + 32 * i, 0, 0], [416 + 32 * i, 128, 16 * (i + 1)], "step"))
    world.append(box([640, 0, 0], [768, 256, 128], "floor"))  # balcony
    for x in (128, 320, 512):
        for y in (224, 384):
            world.append(box([x, y, 0], [x + 32, y + 32, 256], "pillar"))
    write("stairs_pillars.map", "// Stairs (16-unit steps) up to a balcony, and six floor-to-ceiling pillars.",
          world, [point("info_player_start", [64, 64, 24]), marker("stairs_top", [704, 128, 160]),
                  marker("behind_pillars", [64, 448, 64])])

    # thin_leaf.map: the wall between the rooms is two 8-unit slabs 0.01 apart; the doorway
    # crosses the 0.01-thin gap, so sight from A to B passes through a 0.01-thin leaf.
    a = ([0, 0, 0], [256, 256, 128])
    b = ([272, 0, 0], [528, 256, 128])
    solids = carve(shell(*a) + shell(*b), [a, b, ([256, 0, 0], [272, 256, 128])])
    door = ([256, 96, 0], [272, 160, 96])
    walls = carve([([256, 0, 0], [264, 256, 128]), ([264.01, 0, 0], [272, 256, 128])], [door])
    write("thin_leaf.map",
          "// Two rooms whose shared wall is two 8-unit slabs 0.01 units apart (x = 264 and 264.01);\n"
          "// the doorway crosses the gap, so sight from A to B passes through a 0.01-thin leaf.",
          [box(lo, hi) for lo, hi in solids + walls],
          [point("info_player_start", [128, 128, 24]), marker("room_a", [128, 128, 64]),
           marker("room_b", [400, 128, 64])])

    # coplanar.map: two doorways whose frames have faces tilted 1/4096 off the wall plane.
    a = ([0, 0, 0], [256, 256, 128])
    b = ([272, 0, 0], [528, 256, 128])
    doors = [([256, 48, 0], [272, 96, 96]), ([256, 160, 0], [272, 208, 96])]
    solids = carve(shell(*a) + shell(*b), [a, b] + doors)
    mid = ([256, 96, 0], [272, 160, 96])
    solids = carve(solids, [mid])
    world = [box(lo, hi) for lo, hi in solids]
    # The pillar between the doors: its west face is tilted by 1 unit over 4096 about x = 256.
    world.append(Brush([([256, 96, 0], [256, 96, 96], [257, 4192, 0], "wall"),
                        ([272, 96, 0], [272, 160, 0], [272, 96, 96], "wall"),
                        ([256, 96, 0], [272, 96, 0], [256, 96, 96], "wall"),
                        ([256, 160, 0], [272, 160, 0], [256, 160, 96], "wall"),
                        ([256, 96, 0], [272, 96, 0], [256, 160, 0], "wall"),
                        ([256, 96, 96], [272, 96, 96], [256, 160, 96], "wall")], [264, 128, 48]))
    write("coplanar.map",
          "// Two rooms through two doorways; the pillar between them has a face 1/4096 off the wall\n"
          "// plane, so the doorway portals are nearly coplanar. A and B see each other.",
          world, [point("info_player_start", [128, 128, 24]), marker("room_a", [128, 128, 64]),
                  marker("room_b", [400, 128, 64])])

    # valve220.map: two rooms and a corridor in Valve 220 syntax.
    a = ([0, 0, 0], [256, 256, 128])
    corr = ([272, 96, 0], [496, 160, 96])
    b = ([512, 0, 0], [768, 256, 128])
    write("valve220.map", "// Game: Quake\n// Format: Valve\n// two_rooms.map in Valve 220 syntax.",
          rooms([a, corr, b], [([240, 96, 0], [528, 160, 96])]),
          [point("info_player_start", [128, 128, 24])], valve=True, extra_world=[("mapversion", "220")])

    # detail_water.map: a room with a water pool in a floor pit and func_detail crates.
    room = ([0, 0, 0], [512, 512, 192])
    pit = ([192, 192, -64], [320, 320, 0])
    world = rooms([room, pit])
    water = [box([192, 192, -64], [320, 320, -8], "*water0")]
    crates = [box([64, 64, 0], [128, 128, 64], "crate"), box([384, 64, 0], [448, 128, 64], "crate"),
              box([64, 384, 0], [128, 448, 96], "crate")]
    # Liquid brushes are world brushes; their texture gives the contents.
    write("detail_water.map",
          "// A room with a water pool (*water0) in a floor pit and three func_detail crates.",
          world + water, [([("classname", "func_detail")], crates), point("info_player_start", [448, 448, 24]),
                          marker("pool", [256, 256, -32])])

    # scene.obj: a ground slab and three boxes.
    boxes = [([-256, -256, -16], [256, 256, 0]), ([-128, -128, 0], [-64, -64, 64]),
             ([32, -96, 0], [96, 96, 128]), ([-160, 96, 0], [0, 160, 32])]
    lines = ["# Sightline test scene: a ground slab and three boxes (Z up, Quake units)."]
    base = 1
    for n, (lo, hi) in enumerate(boxes):
        lines.append("o box%d" % n)
        for z in (lo[2], hi[2]):
            for y in (lo[1], hi[1]):
                for x in (lo[0], hi[0]):
                    lines.append("v %d %d %d" % (x, y, z))
        # vertex index = base + x + 2y + 4z; quads wound counter-clockwise seen from outside.
        quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        for q in quads:
            lines.append("f " + " ".join(str(base + i) for i in q))
        base += 8
    with open(os.path.join(HERE, "scene.obj"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
