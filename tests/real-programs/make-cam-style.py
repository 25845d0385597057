#!/usr/bin/env python3
"""Writes the CAM-style programs of the corpus (tests/real-programs/cam-*/): six ordinary
milling jobs (facing, a profile with arc lead-in/out, a helical circular pocket, drilling
cycles, a trochoidal slot, engraving) as seven kinds of post-processor print them (habits
taken from publicly documented post output: number format, preamble, arc-centre mode,
retracts). Written for cnc402 (MIT OR Apache-2.0). Run from this folder: python3 make-cam-style.py
"""
import math
import os

STYLES = {
    # name: (folder, units, decimals, arc_mode, line_numbers)
    "fusion-fanuc": ("cam-fanuc", "mm", 3, "ij", 5),
    "fusion-fanuc-inch": ("cam-fanuc", "inch", 4, "ij", 5),
    "fusion-haas": ("cam-haas", "inch", 4, "ij", 0),
    "mastercam-fanuc": ("cam-mastercam", "inch", 4, "r", 2),
    "vectric": ("cam-vectric", "mm", 3, "ij", 0),
    "freecad-linuxcnc": ("cam-freecad", "mm", 3, "ijk", 0),
    "absolute-centres": ("cam-generic", "mm", 4, "abs", 10),
}

PARTS = ["face", "profile", "pocket", "drill", "slot", "engrave"]


class Post:
    def __init__(self, style, scale):
        self.style = style
        _, self.units, self.dec, self.arcs, self.nstep = STYLES[style]
        self.scale = scale  # part size factor, so each style cuts a different part
        self.k = 1 / 25.4 if self.units == "inch" else 1.0
        self.lines = []
        self.n = 0
        self.pos = [0.0, 0.0, 0.0]

    def num(self, v):
        s = f"{v:.{self.dec}f}"
        if self.style.startswith(("fusion", "mastercam")):
            # Fanuc-style: trailing zeros and a leading zero dropped, the point kept.
            s = s.rstrip("0")
            s = s.replace("-0.", "-.") if s.startswith("-0.") else s
            s = s[1:] if s.startswith("0.") and len(s) > 2 else s
            s = "0." if s in (".", "-.", "0.", "-0.") else s
        if s in ("-0.000", "-0.0000"):
            s = s[1:]
        return s

    def emit(self, text):
        if self.nstep and text and not text.startswith(("(", "%", "O")):
            self.n += self.nstep
            text = f"N{self.n} {text}"
        self.lines.append(text)

    def words(self, **axes):
        sep = "" if self.style == "vectric" else " "
        out = []
        for a, v in axes.items():
            out.append(f"{a}{self.num(v * self.k)}")
        return sep.join(out)

    def rapid(self, x=None, y=None, z=None):
        self.move("G0", x, y, z)

    def feed(self, x=None, y=None, z=None, f=None):
        self.move("G1", x, y, z, f)

    def move(self, g, x, y, z, f=None):
        axes = {}
        for i, (a, v) in enumerate((("X", x), ("Y", y), ("Z", z))):
            if v is not None and round(v * self.k, self.dec) != round(self.pos[i] * self.k, self.dec):
                axes[a] = v
                self.pos[i] = v
        if not axes:
            return
        text = g + ("" if self.style == "vectric" else " ") + self.words(**axes)
        if f is not None:
            text += f" F{self.num(f * self.k)}" if self.style != "vectric" else f"F{self.num(f * self.k)}"
        self.emit(text)

    def arc(self, cw, x, y, cx, cy, z=None, f=None):
        """An XY arc from the current point to (x, y) around (cx, cy)."""
        g = "G2" if cw else "G3"
        sx, sy = self.pos[0], self.pos[1]
        axes = {"X": x, "Y": y}
        if z is not None:
            axes["Z"] = z
        text = g + " " + self.words(**axes)
        r = math.hypot(sx - cx, sy - cy)
        full = abs(sx - x) < 1e-9 and abs(sy - y) < 1e-9
        if self.arcs == "r" and not full:
            # R form: positive for at most 180 degrees, negative beyond.
            a0 = math.atan2(sy - cy, sx - cx)
            a1 = math.atan2(y - cy, x - cx)
            sweep = (a0 - a1) if cw else (a1 - a0)
            sweep %= 2 * math.pi
            text += " " + self.words(R=r if sweep <= math.pi else -r)
        elif self.arcs == "abs":
            text += " " + self.words(I=cx, J=cy)
        else:
            text += " " + self.words(I=cx - sx, J=cy - sy)
            if self.arcs == "ijk":
                text += " K" + self.num(0.0)
        if f is not None:
            text += f" F{self.num(f * self.k)}"
        self.emit(text)
        self.pos[0], self.pos[1] = x, y
        if z is not None:
            self.pos[2] = z

    # --- preamble, tool change and end, per post -------------------------------------------
    def start(self, name, number):
        st = self.style
        if st.startswith("fusion"):
            self.emit("%")
            self.emit(f"O{number} ({name.upper()})")
            self.emit(f"(T1 D={self.num(10 * self.k)} CR=0. - ZMIN={self.num(-6 * self.k)} - FLAT END MILL)")
            self.emit("G90 G94 G17 G49 G40 G80" if st != "fusion-haas" else "G90 G94 G17")
            self.emit("G21" if self.units == "mm" else "G20")
            self.emit("G28 G91 Z0." if st != "fusion-haas" else "G53 G0 Z0.")
            self.emit("G90")
        elif st == "mastercam-fanuc":
            self.emit("%")
            self.emit(f"O{number:04d}({name.upper()})")
            self.emit("(MCX FILE - C:\\USERS\\SHOP\\PARTS\\" + name.upper() + ".MCX)")
            self.emit("(T1 |  1/2 FLAT ENDMILL | H1 )")
            self.emit("G20")
            self.emit("G0 G17 G40 G49 G80 G90")
        elif st == "vectric":
            self.emit("%")
            self.emit("(" + name + ".tap)")
            self.emit("G00G21G17G90G40G49G80")
        elif st == "freecad-linuxcnc":
            self.emit("(Exported by FreeCAD)")
            self.emit("(Post Processor: linuxcnc_post)")
            self.emit("(begin preamble)")
            self.emit("G17 G54 G40 G49 G80 G90")
            self.emit("G21")
        else:
            self.emit("%")
            self.emit(f"O{number} ({name})")
            self.emit("G21 G17 G40 G49 G80 G90 G90.1")

    def tool(self, t, rpm, first_xy, clear):
        st = self.style
        if st.startswith("fusion"):
            if t > 1:
                self.emit("M01" if st == "fusion-haas" else "M1")
            self.emit(f"T{t} M6")
            self.emit(f"S{rpm} M3")
            self.emit("G54")
            self.emit("M8")
            self.emit(f"G0 X{self.num(first_xy[0] * self.k)} Y{self.num(first_xy[1] * self.k)}")
            self.pos[0], self.pos[1] = first_xy
            self.emit(f"G43 Z{self.num(clear * self.k)} H{t}")
            self.pos[2] = clear
        elif st == "mastercam-fanuc":
            self.emit(f"T{t} M6")
            self.emit(f"G0 G90 G54 X{self.num(first_xy[0] * self.k)} Y{self.num(first_xy[1] * self.k)} S{rpm} M3")
            self.pos[0], self.pos[1] = first_xy
            self.emit(f"G43 H{t} Z{self.num(clear * self.k)}")
            self.pos[2] = clear
            self.emit("M8")
        elif st == "vectric":
            self.emit(f"T{t}M06")
            self.emit(f"G00G43Z{self.num(clear)}H{t}")
            self.pos[2] = clear
            self.emit(f"S{rpm}M03")
            self.emit("G94")
            self.rapid(*first_xy)
        elif st == "freecad-linuxcnc":
            self.emit(f"(begin operation: TC: Tool{t})")
            self.emit("(machine units: mm/min)")
            self.emit("M5")
            self.emit(f"M6 T{t}")
            self.emit(f"G43 H{t}")
            self.emit(f"M3 S{rpm}")
            self.emit("(finish operation: TC)")
            self.rapid(z=clear)
            self.rapid(*first_xy)
        else:
            self.emit(f"T{t} M6")
            self.emit(f"G0 G43 H{t} Z{self.num(clear)}")
            self.pos[2] = clear
            self.emit(f"S{rpm} M3")
            self.rapid(*first_xy)

    def end(self):
        st = self.style
        if st.startswith("fusion"):
            self.emit("M9")
            self.emit("M5")
            if st == "fusion-haas":
                self.emit("G53 G0 Z0.")
                self.emit("G53 G0 X0. Y0.")
            else:
                self.emit("G28 G91 Z0.")
                self.emit("G90")
                self.emit("G28 G91 X0. Y0.")
                self.emit("G90")
            self.emit("M30")
            self.emit("%")
        elif st == "mastercam-fanuc":
            self.emit("M5")
            self.emit("G91 G28 Z0. M9")
            self.emit("G28 X0. Y0.")
            self.emit("G90")
            self.emit("M30")
            self.emit("%")
        elif st == "vectric":
            self.emit("G00Z20.000")
            self.emit("G00X0.000Y0.000")
            self.emit("M09")
            self.emit("M30")
            self.emit("%")
        elif st == "freecad-linuxcnc":
            self.emit("(begin postamble)")
            self.emit("M05")
            self.emit("G17 G54 G90 G80 G40")
            self.emit("M2")
        else:
            self.emit("G0 Z50.")
            self.emit("G91.1")
            self.emit("M5")
            self.emit("M30")
            self.emit("%")


# --- the parts (millimetres; s scales the part) ------------------------------------------------
def face(p, s):
    w, h, step, r = 80 * s, 50 * s, 8 * s, 4 * s
    p.tool(1, 5000, (-w / 2 - 12, -h / 2), 15)
    p.rapid(z=5)
    p.feed(z=-0.5, f=400)
    y, right = -h / 2, True
    p.feed(x=-w / 2 - 6, f=1200)
    while y < h / 2:
        x_end = w / 2 if right else -w / 2
        p.feed(x=x_end)
        # a 180-degree turn to the next pass
        cx = x_end
        p.arc(right, x_end, y + 2 * r, cx, y + r)
        y += 2 * r
        right = not right
    p.rapid(z=15)


def profile(p, s):
    w, h, rc, tool_r = 60 * s, 40 * s, 6 * s, 5.0
    off = tool_r
    x0, y0 = -w / 2 - off, 0
    p.tool(2, 8000, (x0 - 10, y0 - 10), 15)
    p.rapid(z=3)
    for depth in (-2, -4, -6):
        p.feed(z=depth, f=300)
        # arc lead-in to the left side, tangent
        p.feed(x=x0 - 10, y=y0 - 10, f=900)
        p.feed(x=x0, y=y0 - 10)
        p.feed(y=y0)
        # around the rounded rectangle, climb (CW)
        R = rc + off
        left, right, bot, top = -w / 2 + rc, w / 2 - rc, -h / 2 + rc, h / 2 - rc
        p.feed(x=-w / 2 - off, y=top)
        p.arc(True, left, h / 2 + off, left, top)
        p.feed(x=right)
        p.arc(True, w / 2 + off, top, right, top)
        p.feed(y=bot)
        p.arc(True, right, -h / 2 - off, right, bot)
        p.feed(x=left)
        p.arc(True, -w / 2 - off, bot, left, bot)
        p.feed(y=y0)
        # arc lead-out
        p.arc(False, x0 - 5, y0 + 5, x0 - 5, y0)
        p.rapid(z=3)
        p.rapid(x0 - 10, y0 - 10)
    p.rapid(z=15)


def pocket(p, s):
    cx, cy, R, tool_r = 10 * s, -5 * s, 18 * s, 4.0
    p.tool(3, 9000, (cx + 2, cy), 15)
    p.rapid(z=2)
    p.feed(z=0.5, f=250)
    z = 0.5
    # helical ramp: 1 mm per turn down to -6
    while z > -6 + 1e-9:
        z = max(z - 1, -6)
        p.arc(False, cx + 2, cy, cx, cy, z=z, f=250)
    p.arc(False, cx + 2, cy, cx, cy)
    rr = 2
    while rr < R - tool_r - 1e-9:
        nr = min(rr + 2.5 * s, R - tool_r)
        p.feed(x=cx + nr, f=800)
        p.arc(False, cx + nr, cy, cx, cy)
        rr = nr
    p.feed(x=cx + rr - 1)
    p.rapid(z=15)


def drill(p, s):
    holes = [(x * 15 * s, y * 12 * s) for y in range(-1, 2) for x in range(-2, 3)]
    p.tool(4, 2500, holes[0], 25)
    p.rapid(z=10)
    inch = p.units == "inch"
    q = lambda v: p.num(v * p.k)
    if p.style == "vectric":
        # Vectric has no cycles: plunge and retract
        for (x, y) in holes:
            p.rapid(x, y)
            p.rapid(z=2)
            p.feed(z=-8, f=150)
            p.rapid(z=10)
        p.rapid(z=25)
        return
    x, y = holes[0]
    ret = "G98" if p.style != "mastercam-fanuc" else "G99"
    p.emit(f"{ret} G81 X{q(x)} Y{q(y)} Z{q(-8)} R{q(2)} F{q(150)}")
    for (x, y) in holes[1:5]:
        p.emit(f"X{q(x)} Y{q(y)}")
    p.emit(f"G83 X{q(holes[5][0])} Y{q(holes[5][1])} Z{q(-20)} R{q(2)} Q{q(4)} F{q(120)}")
    for (x, y) in holes[6:10]:
        p.emit(f"X{q(x)} Y{q(y)}")
    p.emit(f"G73 X{q(holes[10][0])} Y{q(holes[10][1])} Z{q(-12)} R{q(2)} Q{q(2)} F{q(150)}")
    for (x, y) in holes[11:]:
        p.emit(f"X{q(x)} Y{q(y)}")
    p.emit("G80")
    p.pos = [holes[-1][0], holes[-1][1], 10.0 if ret == "G98" else 2.0]
    p.rapid(z=25)


def slot(p, s):
    length, width, tool_r, step = 50 * s, 12 * s, 3.0, 0.8
    loop_r = (width / 2 - tool_r) * 0.9 + 0.5
    p.tool(5, 12000, (-length / 2, 0), 15)
    p.rapid(z=2)
    p.feed(z=-3, f=300)
    x = -length / 2
    while x < length / 2:
        # one trochoidal loop: out, around, back, advanced by `step`
        p.arc(False, x + loop_r, 0, x + loop_r / 2, 0, f=1500)
        p.arc(False, x, 0, x + loop_r / 2, 0)
        x += step
        p.feed(x=x)
    p.rapid(z=15)


def engrave(p, s):
    # the outline of the letters "CN" as polylines
    strokes = [
        [(0, 0), (-8, 0), (-10, 3), (-10, 12), (-8, 15), (0, 15)],
        [(5, 0), (5, 15), (15, 0), (15, 15)],
    ]
    p.tool(6, 15000, (strokes[0][0][0] * s, strokes[0][0][1] * s), 10)
    for st in strokes:
        p.rapid(st[0][0] * s, st[0][1] * s)
        p.rapid(z=1)
        p.feed(z=-0.3, f=200)
        for (x, y) in st[1:]:
            p.feed(x * s, y * s, f=600)
        p.rapid(z=5)
    p.rapid(z=10)


JOBS = {"face": face, "profile": profile, "pocket": pocket, "drill": drill, "slot": slot, "engrave": engrave}
EXT = {"fusion-fanuc": "nc", "fusion-fanuc-inch": "nc", "fusion-haas": "nc", "mastercam-fanuc": "NC",
       "vectric": "tap", "freecad-linuxcnc": "ngc", "absolute-centres": "nc"}


def main():
    for i, style in enumerate(STYLES):
        folder = STYLES[style][0]
        os.makedirs(folder, exist_ok=True)
        for j, part in enumerate(PARTS):
            scale = 0.8 + 0.07 * i + 0.05 * j
            p = Post(style, scale)
            p.start(f"{style}-{part}", 1000 + 10 * i + j)
            JOBS[part](p, scale)
            p.end()
            name = f"{folder}/{style}-{part}.{EXT[style]}"
            with open(name, "w") as f:
                f.write("\n".join(p.lines) + "\n")


if __name__ == "__main__":
    main()
