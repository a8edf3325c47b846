#!/usr/bin/env python3
"""Reader for SEM2DPACK dynamic-fault output (our own code, numpy only).

Files written by SEM2DPACK's BC_DYNFLT boundary condition, XX = tag of the
first fault side (05 here):

  FltXX_sem2d.hdr       line 1: names 'NPTS NDAT NSAMP DELT'
                        line 2: their values
                        line 3: field names separated by ':'
                        line 4: 'XPTS ZPTS'
                        then NPTS lines: x z of each output fault node
  FltXX_sem2d.dat       Fortran sequential unformatted, float32.  For each
                        output time (t = it*DELT, it = 0..NSAMP-1) NDAT
                        records of NPTS values; every record is framed by a
                        4-byte little-endian length marker (= 4*NPTS) before
                        and after it.  Field order (NDAT = 6):
                          Slip, Slip_Rate, Shear_Stress, Normal_Stress,
                          Friction, T_stick
                        The two stresses (and T_stick) are CHANGES relative
                        to the initial values (see FltXX_init_sem2d.tab).
  FltXX_init_sem2d.tab  one line per output node: initial shear traction,
                        initial normal traction (tension positive), initial
                        friction coefficient, node weight.

Sign convention (SEM2DPACK bc_dynflt.f90, with tags=5,6): side 1 is the
lower block (z < 0), its outward normal is n1 = (0, +1); slip = u2 - u1
projected on the tangent t = (n1z, -n1x) = (+1, 0), i.e.
slip = u_x(upper) - u_x(lower); the shear traction is the x component of
sigma . n1, i.e. sigma_xz on the fault.  Traction and slip rate have the
same sign (positive sigma_xz drives positive slip).
"""
import numpy as np


def read_header(prefix):
    with open(prefix + ".hdr") as f:
        lines = f.read().splitlines()
    names = lines[0].split()
    vals = lines[1].split()
    hdr = dict(zip(names, vals))
    npts = int(hdr["NPTS"])
    ndat = int(hdr["NDAT"])
    nsamp = int(hdr["NSAMP"])
    delt = float(hdr["DELT"].replace("D", "E"))
    fields = [s.strip() for s in lines[2].split(":")]
    xz = np.array([[float(v.replace("D", "E")) for v in ln.split()]
                   for ln in lines[4:4 + npts]])
    return dict(npts=npts, ndat=ndat, nsamp=nsamp, dt=delt, fields=fields,
                x=xz[:, 0], z=xz[:, 1])


def read_fault(prefix="Flt05_sem2d", init=None):
    """Return dict with t, x, and arrays [nt, npts] for every field.

    Stresses are returned as TOTAL values (initial added) under keys
    'Shear_Stress' and 'Normal_Stress'; the raw increments are kept under
    'dShear_Stress' and 'dNormal_Stress'.
    """
    h = read_header(prefix)
    npts, ndat = h["npts"], h["ndat"]
    raw = np.fromfile(prefix + ".dat", dtype="<i4")
    rec = npts + 2
    nrec = raw.size // rec
    nt = nrec // ndat
    if nt < h["nsamp"]:
        print(f"warning: {prefix}.dat has {nt} complete samples "
              f"(header says {h['nsamp']})")
    raw = raw[: nt * ndat * rec].reshape(nt, ndat, rec)
    if not (np.all(raw[:, :, 0] == 4 * npts) and np.all(raw[:, :, -1] == 4 * npts)):
        raise ValueError("unexpected Fortran record markers")
    data = raw[:, :, 1:-1].copy().view("<f4").astype(np.float64)
    out = dict(t=np.arange(nt) * h["dt"], x=h["x"], z=h["z"], dt=h["dt"])
    for k, name in enumerate(h["fields"][:ndat]):
        out[name] = data[:, k, :]
    if init is None:
        init = prefix.replace("_sem2d", "_init_sem2d") + ".tab"
    ini = np.loadtxt(init)
    out["tau0"] = ini[:, 0]
    out["sn0"] = ini[:, 1]
    out["mu0"] = ini[:, 2]
    out["weight"] = ini[:, 3]
    out["dShear_Stress"] = out["Shear_Stress"]
    out["dNormal_Stress"] = out["Normal_Stress"]
    out["Shear_Stress"] = out["dShear_Stress"] + ini[None, :, 0]
    out["Normal_Stress"] = out["dNormal_Stress"] + ini[None, :, 1]
    return out


if __name__ == "__main__":
    import sys
    d = read_fault(sys.argv[1] if len(sys.argv) > 1 else "Flt05_sem2d")
    print("nt", d["t"].size, "dt", d["dt"], "npts", d["x"].size)
    for k in ("Slip", "Slip_Rate", "Shear_Stress", "Normal_Stress"):
        print(k, d[k].min(), d[k].max())
