"""The zoo's SSP systems (tests/systems) as the tests use them: packed with the FMUs under test,
run by the master, and the answers each scheme must give, computed here independently of the
FMUs' code (closed forms and recurrences in numpy)."""

import csv
import json
import math
import pathlib
import re
import shutil
import subprocess
import zipfile

import numpy as np

from conftest import DIST, REPO
from fmus import MASTER

SYSTEMS = REPO / "tests" / "systems"

# Every coupling scheme of `master run --system`.
SCHEMES = ["jacobi", "gauss-seidel", "gauss-seidel-reversed", "iterative", "ijcsa", "iqn-ils"]
ITERATING = {"iterative", "ijcsa", "iqn-ils"}
# Schemes whose Real inputs over a step are the outputs at its end (once converged), against the
# outputs at its start (Jacobi; Gauss-Seidel for a unit stepped before the one feeding it).
END_VALUES = ITERATING | {"gauss-seidel"}
# Tight interface tolerance: the iterating schemes then agree with the answers to ~1e-12.
TIGHT = ("--tol", "1e-13", "--max-iter", "500")


def ssd_text(name, elements, connections, stop_time=None):
    """The .ssd text of SSP 1.0 system `name`: these elements and connections (SSD text), and a
    default experiment from 0 to `stop_time` if given."""
    experiment = "" if stop_time is None else f'\n  <ssd:DefaultExperiment startTime="0" stopTime="{stop_time}"/>'
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="{name}">
  <ssd:System name="{name}">
    <ssd:Elements>
{elements}
    </ssd:Elements>
    <ssd:Connections>
{connections}
    </ssd:Connections>
  </ssd:System>{experiment}
</ssd:SystemStructureDescription>
"""


def parameter_bindings(name, parameters):
    """A component's <ssd:ParameterBindings> of one inline parameter set `name`: each parameter as
    (name, SSV type, value)."""
    lines = "\n".join(f'                  <ssv:Parameter name="{p}"><ssv:{t} value="{v}"/></ssv:Parameter>'
                      for p, t, v in parameters)
    return f"""        <ssd:ParameterBindings>
          <ssd:ParameterBinding>
            <ssd:ParameterValues>
              <ssv:ParameterSet version="1.0" name="{name}">
                <ssv:Parameters>
{lines}
                </ssv:Parameters>
              </ssv:ParameterSet>
            </ssd:ParameterValues>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>"""


def fmu_file(name):
    path = DIST / f"{name}.fmu"
    if not path.is_file():
        raise AssertionError(f"{path} is missing: run `target/release/master package --out {DIST}` first")
    return path


def _sources(text):
    return re.findall(r'source="([^"]+)"', text)


def pack(name, out_dir, archive=True, edit=None, fmus=None):
    """tests/systems/<name>.ssd with the FMUs under test (its sources `../../dist/<id>.fmu`): an
    `.ssp` archive (FMUs under resources/, .ssv files beside the .ssd), or with `archive=False` a
    directory holding the .ssd (sources pointing at DIST) and its .ssv files. `edit(text)` may
    change the .ssd first (a source it sets elsewhere is left as it is). `fmus` ({id: path})
    replaces FMUs of DIST by others of the same names (e.g. their FMI 3.0 versions)."""
    fmus_by_id = fmus or {}
    fmu_path = lambda stem: fmus_by_id.get(stem) or fmu_file(stem)  # noqa: E731
    text = (SYSTEMS / f"{name}.ssd").read_text()
    if edit is not None:
        text = edit(text)
    sources = [s for s in _sources(text) if s.startswith("../../dist/")]
    ssvs = [s for s in _sources(text) if s.endswith(".ssv")]
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not archive:
        for s in sources:
            text = text.replace(f'source="{s}"', f'source="{fmu_path(pathlib.Path(s).stem)}"')
        (out_dir / f"{name}.ssd").write_text(text)
        for s in ssvs:
            shutil.copy(SYSTEMS / s, out_dir / s)
        return out_dir / f"{name}.ssd"
    path = out_dir / f"{name}.ssp"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for s in sorted(set(sources)):
            stem = pathlib.Path(s).stem
            text = text.replace(f'source="{s}"', f'source="resources/{stem}.fmu"')
            z.write(fmu_path(stem), f"resources/{stem}.fmu")
        z.writestr("SystemStructure.ssd", text)
        for s in ssvs:
            z.write(SYSTEMS / s, s)
    return path


def run(system, scheme, dt, *extra, t_end=None, out_dir=None, expect_ok=True):
    """`master run --system` with a CSV and JSON; returns (columns by name, json, completed process)."""
    out_dir = pathlib.Path(out_dir or pathlib.Path(system).parent)
    csv_path = out_dir / f"{pathlib.Path(system).stem}-{scheme}-{dt}.csv"
    cmd = [str(MASTER), "run", "--system", str(system), "--scheme", scheme, "--dt", repr(dt),
           "--out", str(csv_path), "--json", *extra]
    if str(system).endswith(".ssd"):
        cmd.append("--allow-external-fmus")  # its FMUs are those in DIST, outside its folder
    if t_end is not None:
        cmd += ["--t-end", repr(t_end)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if not expect_ok:
        return None, None, p
    assert p.returncode == 0, f"{' '.join(cmd)}\n{p.stderr}"
    return read_csv(csv_path), json.loads(p.stdout), p


def read_csv(path):
    """Columns of the master's CSV by name: numbers as float arrays, text as lists."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    columns = {}
    for j, name in enumerate(header):
        values = [r[j] for r in body]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            columns[name] = values
    return columns


# --- answers ----------------------------------------------------------------------------------


def dahlquist_steps(k, x0, h, inputs):
    """x after each step of x' = -k x + u with u held at inputs[n] over step n (exact): the
    states at t_0 … t_N."""
    e = math.exp(-k * h)
    gain = -math.expm1(-k * h) / k
    x = [x0]
    for u in inputs:
        x.append(e * x[-1] + gain * u)
    return np.array(x)


def delayed(values, scheme):
    """What a unit fed by `values` (outputs of a unit at t_0 … t_N that steps first, with
    nothing feeding it) holds over step n: the value at t_{n+1} (end values) or at t_n."""
    return values[1:] if scheme in END_VALUES else values[:-1]


def ball_exact(t, h0=1.0, g=9.81, e=0.7, v_min=0.1):
    """Height, velocity, impacts and rest of the bouncing ball dropped from h0 at rest: the
    impact times summed up flight by flight, the arcs between them in closed form."""
    t = np.asarray(t, dtype=float)
    h, v = np.zeros_like(t), np.zeros_like(t)
    bounces, resting = np.zeros(t.shape, dtype=int), np.zeros(t.shape, dtype=bool)
    # flight k starts at t_k from height z_k with speed w_k
    starts = [(0.0, h0, 0.0)]
    t_fall = math.sqrt(2.0 * h0 / g)
    impact_speed = g * t_fall
    t_k = t_fall
    rest_time = math.inf
    while True:
        w = e * impact_speed
        if w <= v_min:
            rest_time = t_k
            break
        starts.append((t_k, 0.0, w))
        t_k += 2.0 * w / g
        impact_speed = w
    for i, ti in enumerate(t):
        if ti >= rest_time:
            bounces[i], resting[i] = len(starts), True
            continue
        k = max(j for j, s in enumerate(starts) if s[0] <= ti)
        t0, z0, w0 = starts[k]
        s = ti - t0
        h[i], v[i], bounces[i] = z0 + w0 * s - 0.5 * g * s * s, w0 - g * s, k
    return h, v, bounces, resting


def read_table(path):
    """A table file of the resource FMU: (title, times, values), parsed here on its own."""
    title, ts, ys = "", [], []
    for line in pathlib.Path(path).read_text().splitlines():
        line = line.split("#")[0].strip()
        if not line:
            continue
        if "=" in line:
            title = line.split("=", 1)[1].strip()
            continue
        a, b = line.replace(",", " ").split()
        ts.append(float(a))
        ys.append(float(b))
    return title, np.array(ts), np.array(ys)


def rk4_van_der_pol(t_end, dt, x0, x1, mu=1.0):
    """Van der Pol's oscillator (no forcing) by classical RK4 at the fine step `dt`, written here
    on its own: the state at every step from 0 to `t_end` (the caller takes every k-th row)."""
    n = round(t_end / dt)
    x = np.array([x0, x1], dtype=float)
    out = np.empty((n + 1, 2))
    out[0] = x

    def f(x):
        return np.array([x[1], mu * (1.0 - x[0] ** 2) * x[1] - x[0]])

    for i in range(n):
        k1 = f(x)
        k2 = f(x + 0.5 * dt * k1)
        k3 = f(x + 0.5 * dt * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[i + 1] = x
    return out


def chain_expected(t, scheme):
    """chain.ssd: x1 = 1 - e^{-t} exactly; f passes it on; x2 from the input d2 holds."""
    h = t[1] - t[0]
    x1 = 1.0 - np.exp(-t)
    if scheme in END_VALUES:
        f_out = x1.copy()
        u2 = x1[1:]
    else:
        # f steps with x1(t_n): its output at t_{n+1} is x1(t_n); d2 takes f's output at t_n
        f_out = np.concatenate([[x1[0]], x1[:-1]])
        u2 = f_out[:-1]
    return x1, f_out, dahlquist_steps(2.0, 0.0, h, u2)


def sampled_expected(h, n_steps, scheme, every=4, gain=2.0, x0=1.0):
    """sampled.ssd at macro step h: p.x at t_0 … t_N and the sampler c's output there (held
    between its steps, every `every` macro steps). Over macro step n the plant's input is
    u = -gain · s, s the sampler's output: x0 (its input at the start) until its first step,
    then what it took at its last communication point t_j = j·every·h — p.x(t_j) for the schemes
    that couple end values, p.x(t_j − h) for Jacobi and Gauss-Seidel reversed (it steps with the
    outputs at the start of the macro step that ends at t_j). Each step exact with u held."""
    e, g = math.exp(-h), -math.expm1(-h)
    x, held, out = [x0], x0, [x0]
    for n in range(n_steps):
        x.append(e * x[-1] + g * (-gain * held))
        if (n + 1) % every == 0:
            # the sampler's step ends at t_{n+1}
            held = x[-1] if scheme in END_VALUES else x[-2]
        out.append(held)
    return np.array(x), np.array(out)


def check_oscillators(cols, scheme):
    """oscillators.ssd at h = 0.05 s: van der Pol against RK4 at a fine step, and d stepped
    exactly with the inputs the scheme gives it."""
    ref = rk4_van_der_pol(10.0, 1e-4, 0.0, 2.0)[::500]
    assert np.max(np.abs(cols["vdp.x0"] - ref[:, 0])) < 1e-9
    x = dahlquist_steps(1.0, 0.0, 0.05, delayed(cols["vdp.x0"], scheme))
    assert np.max(np.abs(cols["d.x"] - x)) < 1e-12


def loop_expected(t):
    """loop.ssd, solved every step with d.u held at its end value u = 2x/3 (the loop's
    equation): x_{n+1} = x_n e^{-h} / (1 - (2/3)(1 - e^{-h}))."""
    h = t[1] - t[0]
    rho = math.exp(-h) / (1.0 - 2.0 / 3.0 * -math.expm1(-h))
    return rho ** np.arange(len(t))
