"""Reading shader-node sockets as numbers, or as an affine function of one volume grid.

Brume's `BRUME_medium_vdb` can express a socket that is a constant, or `scale * grid + offset`
for a grid of the .vdb file (an Attribute node, optionally through Math or Map Range nodes).
Anything else raises `Unsupported` with a description of what was found, and the caller turns
it into a refusal naming the object, material and socket.
"""


class Unsupported(Exception):
    """A node set-up Brume cannot express."""


class Affine:
    """`scale * grid + offset`; `grid` None means the constant `offset`."""

    def __init__(self, grid=None, scale=0.0, offset=0.0, notes=()):
        self.grid = grid
        self.scale = scale
        self.offset = offset
        self.notes = list(notes)  # warnings met on the way (ignored clamps)

    @staticmethod
    def const(v):
        return Affine(None, 0.0, float(v))

    def mul(self, c):
        return Affine(self.grid, self.scale * c, self.offset * c, self.notes)

    def add(self, c):
        return Affine(self.grid, self.scale, self.offset + c, self.notes)


def describe(node):
    kind = node.bl_idname
    if kind == "ShaderNodeMath":
        return f"Math node '{node.name}' ({node.operation})"
    return f"{node.bl_label} node '{node.name}'"


def source(socket):
    """The output socket feeding `socket` through reroutes and muted links, or None."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        out = link.from_socket
        if out.node.bl_idname == "NodeReroute":
            socket = out.node.inputs[0]
            continue
        return out
    return None


def _value(socket):
    v = socket.default_value
    try:
        return float(v)
    except TypeError:
        raise Unsupported(f"socket '{socket.name}' holds a vector, not a number")


def affine(socket):
    """The value of a float input socket as an `Affine`."""
    out = source(socket)
    if out is None:
        return Affine.const(_value(socket))
    node = out.node
    if node.mute:
        raise Unsupported(f"{describe(node)} is muted")
    kind = node.bl_idname
    if kind == "ShaderNodeAttribute":
        if out.identifier != "Fac":
            raise Unsupported(f"{describe(node)}: output '{out.name}' (only 'Fac' is a float grid)")
        if node.attribute_type != "GEOMETRY":
            raise Unsupported(f"{describe(node)}: attribute type {node.attribute_type} (GEOMETRY needed)")
        return Affine(node.attribute_name, 1.0, 0.0)
    if kind == "ShaderNodeValue":
        return Affine.const(out.default_value)
    if kind == "ShaderNodeMath":
        return _math(node)
    if kind == "ShaderNodeMapRange":
        return _map_range(node)
    raise Unsupported(f"{describe(node)} drives it")


def _constant(a, node):
    if a.grid is not None:
        raise Unsupported(f"{describe(node)} combines two grids")
    return a.offset


def _math(node):
    op = node.operation
    ins = [i for i in node.inputs if i.enabled]
    notes = []
    if node.use_clamp:
        notes.append(f"{describe(node)}: 'Clamp' is ignored (Brume does not clamp)")
    if op == "MULTIPLY":
        a, b = affine(ins[0]), affine(ins[1])
        r = a.mul(_constant(b, node)) if b.grid is None else b.mul(_constant(a, node))
    elif op == "ADD":
        a, b = affine(ins[0]), affine(ins[1])
        r = a.add(_constant(b, node)) if b.grid is None else b.add(_constant(a, node))
    elif op == "SUBTRACT":
        a, b = affine(ins[0]), affine(ins[1])
        r = a.add(-_constant(b, node)) if b.grid is None else b.mul(-1.0).add(_constant(a, node))
    elif op == "DIVIDE":
        a, b = affine(ins[0]), affine(ins[1])
        c = _constant(b, node)
        if c == 0.0:
            raise Unsupported(f"{describe(node)} divides by zero")
        r = a.mul(1.0 / c)
    elif op == "MULTIPLY_ADD":
        a, b, c = affine(ins[0]), affine(ins[1]), affine(ins[2])
        prod = a.mul(_constant(b, node)) if b.grid is None else b.mul(_constant(a, node))
        r = prod.add(_constant(c, node))
    else:
        raise Unsupported(f"{describe(node)}: only Multiply, Add, Subtract, Divide and Multiply Add are read")
    r.notes = notes + r.notes
    return r


def _map_range(node):
    if node.data_type != "FLOAT" or node.interpolation_type != "LINEAR":
        raise Unsupported(f"{describe(node)}: only Float, Linear is read")
    ins = {i.identifier: i for i in node.inputs}
    v = affine(ins["Value"])
    lo, hi = (_constant(affine(ins[k]), node) for k in ("From Min", "From Max"))
    to_lo, to_hi = (_constant(affine(ins[k]), node) for k in ("To Min", "To Max"))
    if hi == lo:
        raise Unsupported(f"{describe(node)}: From Min equals From Max")
    s = (to_hi - to_lo) / (hi - lo)
    r = v.add(-lo).mul(s).add(to_lo)
    if node.clamp:
        r.notes.insert(0, f"{describe(node)}: 'Clamp' is ignored (Brume does not clamp)")
    return r


def color(socket, what):
    """An unlinked RGB(A) socket as [r, g, b]."""
    if source(socket) is not None:
        raise Unsupported(f"'{socket.name}' is linked ({describe(source(socket).node)}); {what}")
    return [float(c) for c in socket.default_value[:3]]
