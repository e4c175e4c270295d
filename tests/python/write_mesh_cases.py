#!/usr/bin/env python3
"""Write small unstructured-mesh NetCDF files as models and conventions write them
(netCDF4-python and numpy only: deterministic data, no randomness from a generator's stream,
nothing read from the network) and compute, by brute force over every cell, the values a
resampling onto a regular longitude-latitude grid must give: the reference of hdrvis's
unstructured-mesh tests.

    python3 tests/python/write_mesh_cases.py write OUT_DIR
    python3 tests/python/write_mesh_cases.py sample OUT_DIR REQUEST.json
    python3 tests/python/write_mesh_cases.py check OUT_DIR

write: the files below (each under 300 kB) and OUT_DIR/cases.json; prints a table of them.
  ugrid.nc          UGRID 1.0, regional (lon 0..30, lat 0..20): 143 nodes on a 13 x 11 lattice
                    (interior nodes jittered, boundary nodes slid along the boundary), 150 faces:
                    90 quadrilaterals and 60 triangles (30 quads split), counter-clockwise.
                    mesh2 (int, cf_role mesh_topology, topology_dimension 2, node_coordinates
                    "mesh2_node_x mesh2_node_y", face_node_connectivity "mesh2_face_nodes",
                    face_dimension "nMesh2_face", face_coordinates "mesh2_face_x mesh2_face_y"),
                    mesh2_node_x/_y(nMesh2_node) degrees_east/north, mesh2_face_x/_y(nMesh2_face)
                    (mean of the face's nodes), mesh2_face_nodes(nMesh2_face, nMaxMesh2_face_nodes=4)
                    int32, _FillValue -1 (4th entry of triangles), start_index 0;
                    time(time=2) "hours since 2020-01-01" [0, 6];
                    depth(nMesh2_face) m (face), temp(time, nMesh2_face) float32 (face,
                    _FillValue -9999: face 7 missing at time 1), elev(nMesh2_node) float64
                    (node): exactly 100 + 3 lon - 2 lat.
  ugrid_1based.nc   the same mesh, start_index 1, _FillValue 999999; depth only.
  icon_grid.nc      ICON grid: icosahedron with vertices at both poles, each triangle subdivided
                    twice (points projected to the unit sphere): 320 cells, 162 vertices.
                    dims cell, vertex, nv=3; clon/clat(cell) radian (normalised centroids,
                    standard_name longitude/latitude, bounds "clon_vertices"/"clat_vertices"),
                    clon_vertices/clat_vertices(cell, nv) radian (counter-clockwise seen from
                    outside), vlon/vlat(vertex) radian, vertex_of_cell(nv, cell) int 1-based;
                    longitudes in [-pi, pi]; global uuidOfHGrid, number_of_grid_used 1.
  icon_data.nc      as CDI writes ICON output: dims time=2 (unlimited), depth=3, ncells=320,
                    vertices=3; clon/clat(ncells) radian with bounds "clon_bnds"/"clat_bnds"
                    (CDI's names, on dim `vertices`); S(time, depth, ncells) float32,
                    CDI_grid_type "unstructured", coordinates "clat clon",
                    number_of_grid_in_reference 1, _FillValue = missing_value = -9e33 (CDI's):
                    S = 35 + cos(clat) sin(2 clon) + depth index + 0.5 time index, missing at
                    depth index 2 where clat > 60 degrees.
  icon_data_only.nc the same S without any coordinates (read with icon_grid.nc).
  mpas_grid.nc      MPAS Voronoi mesh, the dual of icon_grid.nc's mesh (NetCDF-3 64-bit offset,
                    as MPAS writes): nCells=162 (12 pentagons, 150 hexagons), nVertices=320
                    (normalised triangle centroids), maxEdges=6, vertexDegree=3; latCell,
                    lonCell(nCells), latVertex, lonVertex(nVertices) radians, longitudes in
                    [0, 2 pi); xCell.. zVertex; nEdgesOnCell(nCells) int; verticesOnCell(nCells,
                    maxEdges) int 1-based, counter-clockwise seen from outside, 0 past
                    nEdgesOnCell; cellsOnVertex(nVertices, vertexDegree) 1-based;
                    indexToCellID, indexToVertexID; global on_a_sphere "YES", sphere_radius 1.0.
  mpas_data.nc      no geometry: dims Time=2 (unlimited), nCells, nVertLevels=2, nVertices,
                    StrLen=64; xtime(Time, StrLen) char; temperature(Time, nCells, nVertLevels)
                    (face) = 280 + 20 cos(latCell) + sin(lonCell) - 5 level + time;
                    vorticity(Time, nVertices) (node) = 1 + 0.01 lon + 0.02 lat + 0.5 time,
                    lon in degrees wrapped to [-180, 180) (linear within any cell off the seam).
  scrip_grid.nc     SCRIP: grid_size=96 (12 x 8 quads, sheared, lon ~100..124, lat ~-10..6),
                    grid_corners=4, grid_rank=2; grid_dims(grid_rank) = [12, 8];
                    grid_center_lat/lon(grid_size), grid_corner_lat/lon(grid_size, grid_corners)
                    units "degrees" (corners counter-clockwise), grid_imask(grid_size) all 1.
  scrip_grid_radians.nc  the same grid with units "radians".
  scrip_data.nc     T850(ncol=96) float32 K, as CAM-SE/E3SM write data on ncol.
  fvcom.nc          FVCOM (lon -70..-69, lat 41..42): node=64 (8 x 8 lattice, jittered),
                    nele=98 triangles (each lattice quad split along a hashed diagonal),
                    three=3, time=2 (unlimited, days since 1858-11-17 00:00:00), siglay=2;
                    lon, lat(node), lonc, latc(nele) (mean of the 3 nodes), nv(three, nele) int
                    1-based, CLOCKWISE as FVCOM stores elements; h(node);
                    zeta(time, node) float64 (node) = 0.5 + 0.01 lon - 0.02 lat + 0.1 time;
                    temp(time, siglay, nele) float32 (face).
  adcirc.nc         ADCIRC fort.63.nc, the older form without a mesh topology variable
                    (lon -90..-88.5, lat 28.5..29.7): node=63 (9 x 7 lattice, jittered),
                    nele=96, nvertex=3, time=2 (unlimited, seconds since 2020-01-01);
                    x, y(node) longitude/latitude degrees_east/north; element(nele, nvertex) int
                    1-based (long_name "element", units "nondimensional"), counter-clockwise;
                    depth(node); zeta(time, node) float64, _FillValue -99999 (node):
                    0.5 + 0.01 x - 0.02 y + 0.1 time, node 30 dry (missing) at time 1.
  camse.nc          CAM-SE history output on its native grid: 600 columns (ncol) with only their
                    centres, lat(ncol) and lon(ncol) in degrees (lon in [0, 360), a nudged
                    Fibonacci sphere), area(ncol), T850(time, ncol) and lin(ncol) = 2 + 0.01 lon +
                    0.03 lat; its cells for the reference are the spherical Delaunay triangles of
                    the centres, the faces of their convex hull (scipy's qhull), values on nodes
  Bad files, each one fault:
  bad_index.nc      ugrid.nc with face 10's second entry = number of nodes + 5.
  bad_polygon.nc    ugrid.nc with face 10 having only 2 valid nodes.
  bad_units.nc      icon_data.nc with clon, clat, clon_bnds, clat_bnds in units "furlongs".
  icon_data_mismatch.nc  icon_data_only.nc with ncells = 319 (icon_grid.nc has 320 cells).
  icon_data_other_grid.nc  icon_data_only.nc naming another grid (uuidOfHGrid) of 320 cells.
cases.json: {"files": [{"file", "kind", "grid" (the grid file to read it with, or null),
  "format", "dims" {name: length}, "faces", "nodes" (counts, null where the file has no
  geometry of its own nor a grid), "face_dim", "node_dim", "face_variables",
  "node_variables", "linear" {variable: formula}, "missing" {variable: description},
  "fault" (null for good files), "notes"}, ...], "geometry": {the tolerances of `sample`}}.

sample: REQUEST.json is {"file": NAME, "grid": null or NAME, "variable": NAME, "index": {DIM:
  INT, ...}, "lon": [...], "lat": [...]} (NAME relative to OUT_DIR; every dimension of the
  variable but the mesh's must be in index unless of length 1), with "points": [[lon, lat], ...]
  in place of the axes for points anywhere, and optionally "mesh": how to read the geometry of
  a real file (mesh_from_spec) in place of the rules for the files written here. Prints one JSON object
  {"values": [...]}: one entry per point of the regular grid, lat rows, lon fastest: the value
  (float), null where no cell contains the point or the data there are missing, "edge" where the
  point is within 1e-9 degrees of an edge or vertex of any cell. The geometry, by brute force
  over every cell (no spatial index):
  - coordinates in degrees (radians converted); a cell is the polygon of its vertices in order,
    joined by straight lines in the (longitude, latitude) plane;
  - longitudes are unwrapped from the cell's first vertex (not at a pole): each is shifted by a
    multiple of 360 into [prev - 180, prev + 180) of the previous unwrapped one;
  - a vertex at a pole (|lat| >= 90 - 5e-5) is replaced by two vertices at that pole (lat +-90)
    at the unwrapped longitudes of its previous and next vertices (cyclic, pole vertices
    ignored), previous first; in node data both take the pole vertex's own value;
  - a ring round a pole (the closing step, last to first unwrapped the same way, brings the
    first vertex back 360 away, within 1e-6) is closed along the pole: appended are the first
    vertex again at its longitude +-360, then that longitude and the first vertex's at
    pole_lat (+90 if the mean vertex latitude > 0, else -90); in node data the re-appended
    first vertex keeps its value and the two pole vertices take the mean of the cell's
    vertex values;
  - a point is in a cell when the crossing-number rule puts it, shifted by -720, -360, 0, 360
    or 720 degrees of longitude, inside the polygon; the first cell in file order wins;
  - face data: that cell's value; node data: barycentric over the first of the cell's
    triangles that holds the point (weights >= -1e-12; zero-area triangles skipped): the fan
    (v0, vk, vk+1), k = 1..n-2 of the final polygon, or for a ring round a pole two triangles
    per ring edge down to the pole, (a, b, pole below b) and (a, pole below b, pole below a)
    with a the edge's western end,
    the pole's value the mean of the ring's; missing data in the cell's value or any of its
    vertex values give null (the cell counts as no cell).
  Exit status 1 with a message on stderr for a file it cannot read (the bad files).

check: samples every exactly-linear node field (ugrid elev, mpas vorticity, fvcom zeta, adcirc
  zeta) at deterministic pseudo-random interior points and asserts the linear formula to 1e-9;
  checks that every face value is found at its cell's centre, that the global meshes (ICON,
  MPAS) cover every point exactly once, and that the poles are covered; exits 1 on a failure.
Exit status 77 (skipped) when a module is missing.
"""

import json
import math
import os
import sys

try:
    import netCDF4
    import numpy as np
except ImportError as exc:  # pragma: no cover - depends on the machine
    print(f"SKIP: {exc} (pip install -r tests/python/requirements.txt)", file=sys.stderr)
    sys.exit(77)

EDGE_TOL = 1e-9  # degrees: a point this close to an edge or vertex is "edge"
POLE_TOL = 5e-5  # degrees: a vertex with |lat| >= 90 - POLE_TOL is at a pole (float32 radians
#                  put the pole up to 2e-5 degrees off it)
RING_TOL = 1e-6  # degrees: a ring whose closing brings the first vertex 360 +- this round
BARY_TOL = 1e-12  # barycentric weight tolerance of the fan triangles
SHIFTS = (-720.0, -360.0, 0.0, 360.0, 720.0)
UUID = "6f1c2b6e-0d1a-4c3e-9a55-1c0e5a7d3b21"  # the ICON files' uuidOfHGrid (made up, fixed)
OTHER_UUID = "0b7e2f4a-5c1d-4e8f-8a3b-2d9c6e1f7a40"  # another grid of the same size


class Fail(Exception):
    """A file the reference cannot read (sample exits 1)."""


# -- deterministic meshes --------------------------------------------------------------------------


def hash01(i, j, salt):
    """A deterministic pseudo-random number in [0, 1) of integers (no generator stream)."""
    h = (i * 73856093) ^ (j * 19349663) ^ (salt * 83492791)
    h = (h * 2654435761 + 0x9E3779B9) & 0xFFFFFFFF
    h ^= h >> 16
    h = (h * 0x45D9F3B) & 0xFFFFFFFF
    h ^= h >> 16
    return h / 4294967296.0


def jittered_lattice(lon0, lon1, nx, lat0, lat1, ny, amp, salt):
    """(ny+1) x (nx+1) nodes, lat-major (node = j (nx+1) + i): interior nodes moved by up to
    amp steps along each axis, boundary nodes slid along their boundary, corners fixed."""
    dx, dy = (lon1 - lon0) / nx, (lat1 - lat0) / ny
    lon = np.empty((ny + 1) * (nx + 1))
    lat = np.empty_like(lon)
    for j in range(ny + 1):
        for i in range(nx + 1):
            jx = amp * (2 * hash01(i, j, salt) - 1)
            jy = amp * (2 * hash01(i, j, salt + 1) - 1)
            if i in (0, nx):
                jx = 0.0
            if j in (0, ny):
                jy = 0.0
            k = j * (nx + 1) + i
            lon[k] = lon0 + (i + jx) * dx
            lat[k] = lat0 + (j + jy) * dy
    return lon, lat


def signed_area2(xs, ys):
    return float(np.sum(xs * np.roll(ys, -1) - np.roll(xs, -1) * ys))


def is_convex(xs, ys):
    n = len(xs)
    signs = set()
    for k in range(n):
        ax, ay = xs[(k + 1) % n] - xs[k], ys[(k + 1) % n] - ys[k]
        bx, by = xs[(k + 2) % n] - xs[(k + 1) % n], ys[(k + 2) % n] - ys[(k + 1) % n]
        c = ax * by - ay * bx
        if c != 0:
            signs.add(c > 0)
    return len(signs) <= 1


def lattice_quads(nx):
    """The counter-clockwise quads (i, j) of a lattice of nx+1 nodes per row."""
    def quad(i, j):
        a = j * (nx + 1) + i
        return [a, a + 1, a + nx + 2, a + nx + 1]
    return quad


def ugrid_mesh():
    nx, ny = 12, 10
    lon, lat = jittered_lattice(0.0, 30.0, nx, 0.0, 20.0, ny, 0.25, 1)
    quad = lattice_quads(nx)
    faces = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = quad(i, j)
            if not is_convex(lon[[a, b, c, d]], lat[[a, b, c, d]]):
                raise AssertionError(f"ugrid quad {i},{j} is not convex")
            if (i + 2 * j) % 4 == 0:  # 30 of the 120 quads split, alternating diagonals
                faces += [[a, b, c], [a, c, d]] if j % 2 == 0 else [[a, b, d], [b, c, d]]
            else:
                faces.append([a, b, c, d])
    return lon, lat, faces


def triangle_patch(lon0, lon1, nx, lat0, lat1, ny, salt, clockwise):
    """A jittered lattice with each (convex) quad split along a hashed diagonal."""
    lon, lat = jittered_lattice(lon0, lon1, nx, lat0, lat1, ny, 0.3, salt)
    quad = lattice_quads(nx)
    tris = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = quad(i, j)
            if not is_convex(lon[[a, b, c, d]], lat[[a, b, c, d]]):
                raise AssertionError(f"patch quad {i},{j} is not convex")
            pair = [[a, b, c], [a, c, d]] if hash01(i, j, salt + 7) < 0.5 else [[a, b, d], [b, c, d]]
            tris += [t[::-1] for t in pair] if clockwise else pair
    return lon, lat, tris


def icosphere(levels=2):
    """Unit-sphere points and counter-clockwise (outward) triangles of an icosahedron with
    vertices at both poles, each triangle split in 4 `levels` times, midpoints projected."""
    t = math.atan(0.5)
    pts = [(0.0, 0.0, 1.0)]
    for k in range(5):
        a = math.radians(72.0 * k)
        pts.append((math.cos(t) * math.cos(a), math.cos(t) * math.sin(a), math.sin(t)))
    for k in range(5):
        a = math.radians(36.0 + 72.0 * k)
        pts.append((math.cos(t) * math.cos(a), math.cos(t) * math.sin(a), -math.sin(t)))
    pts.append((0.0, 0.0, -1.0))
    pts = [np.array(p) for p in pts]
    tris = []
    for k in range(5):
        u0, u1 = 1 + k, 1 + (k + 1) % 5
        l0, l1 = 6 + k, 6 + (k + 1) % 5
        tris += [[0, u0, u1], [u0, l0, u1], [u1, l0, l1], [l0, 11, l1]]
    for _ in range(levels):
        mid = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = pts[a] + pts[b]
                pts.append(m / np.linalg.norm(m))
                mid[key] = len(pts) - 1
            return mid[key]

        new = []
        for a, b, c in tris:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
        tris = new
    xyz = np.array(pts)
    tris = np.array(tris)
    for n, (a, b, c) in enumerate(tris):
        if np.dot(np.cross(xyz[b] - xyz[a], xyz[c] - xyz[a]), xyz[a]) < 0:
            tris[n] = [a, c, b]
    return xyz, tris


def to_lonlat(xyz):
    """Longitude in [-pi, pi] and latitude, radians."""
    return np.arctan2(xyz[:, 1], xyz[:, 0]), np.arcsin(np.clip(xyz[:, 2], -1.0, 1.0))


def icon_mesh(level=2):
    xyz, tris = icosphere(level)
    centres = xyz[tris].sum(axis=1)
    centres /= np.linalg.norm(centres, axis=1)[:, None]
    vlon, vlat = to_lonlat(xyz)
    clon, clat = to_lonlat(centres)
    return xyz, tris, centres, vlon, vlat, clon, clat


def mpas_mesh(level=2):
    """The Voronoi dual of icon_mesh(level): cells at the icosahedral points, vertices at the
    triangles' centres, each cell's vertices counter-clockwise seen from outside."""
    xyz, tris, centres, _, _, _, _ = icon_mesh(level)
    around = [[] for _ in range(len(xyz))]
    for n, tri in enumerate(tris):
        for v in tri:
            around[v].append(n)
    vertices_on_cell = []
    for c, r in enumerate(xyz):
        e = np.cross([0.0, 0.0, 1.0], r) if abs(r[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        e = e - np.dot(e, r) * r
        e /= np.linalg.norm(e)
        f = np.cross(r, e)
        ang = [math.atan2(np.dot(centres[t], f), np.dot(centres[t], e)) for t in around[c]]
        vertices_on_cell.append([around[c][k] for k in np.argsort(ang)])
    return xyz, tris, centres, vertices_on_cell


def lon_0_2pi(lon):
    lon = np.mod(lon, 2 * np.pi)
    return np.where(lon >= 2 * np.pi, 0.0, lon)


def wrap180(lon_deg):
    return np.where(lon_deg >= 180.0, lon_deg - 360.0, lon_deg)


# -- writers ---------------------------------------------------------------------------------------


def add_var(ds, name, dtype, dims, values=None, fill=None, **attrs):
    v = ds.createVariable(name, dtype, dims, fill_value=fill)
    for key, value in attrs.items():
        v.setncattr(key, value)
    if values is not None:
        v[...] = values
    return v


def write_ugrid(path, one_based=False, fault=None):
    lon, lat, faces = ugrid_mesh()
    nf, nn = len(faces), len(lon)
    fill = 999999 if one_based else -1
    base = 1 if one_based else 0
    conn = np.full((nf, 4), fill, dtype=np.int32)
    for k, f in enumerate(faces):
        conn[k, :len(f)] = np.array(f) + base
    fx = np.array([lon[f].mean() for f in faces])
    fy = np.array([lat[f].mean() for f in faces])
    if fault == "index":
        conn[10, 1] = nn + 5
    elif fault == "polygon":
        conn[10, 2:] = fill
    with netCDF4.Dataset(path, "w", format="NETCDF4") as ds:
        ds.Conventions = "CF-1.8 UGRID-1.0"
        ds.title = "hdrvis test mesh: UGRID 2-D flexible mesh, mixed triangles and quadrilaterals"
        ds.createDimension("nMesh2_node", nn)
        ds.createDimension("nMesh2_face", nf)
        ds.createDimension("nMaxMesh2_face_nodes", 4)
        if not one_based:
            ds.createDimension("time", 2)
        m = add_var(ds, "mesh2", "i4", ())
        m.cf_role = "mesh_topology"
        m.long_name = "Topology data of 2D unstructured mesh"
        m.topology_dimension = np.int32(2)
        m.node_coordinates = "mesh2_node_x mesh2_node_y"
        m.face_node_connectivity = "mesh2_face_nodes"
        m.face_dimension = "nMesh2_face"
        m.face_coordinates = "mesh2_face_x mesh2_face_y"
        add_var(ds, "mesh2_node_x", "f8", ("nMesh2_node",), lon, standard_name="longitude",
                long_name="Longitude of 2D mesh nodes.", units="degrees_east")
        add_var(ds, "mesh2_node_y", "f8", ("nMesh2_node",), lat, standard_name="latitude",
                long_name="Latitude of 2D mesh nodes.", units="degrees_north")
        add_var(ds, "mesh2_face_x", "f8", ("nMesh2_face",), fx, standard_name="longitude",
                long_name="Characteristics longitude of 2D mesh face.", units="degrees_east")
        add_var(ds, "mesh2_face_y", "f8", ("nMesh2_face",), fy, standard_name="latitude",
                long_name="Characteristics latitude of 2D mesh face.", units="degrees_north")
        c = add_var(ds, "mesh2_face_nodes", "i4", ("nMesh2_face", "nMaxMesh2_face_nodes"), fill=fill,
                    cf_role="face_node_connectivity", long_name="Maps every face to its corner nodes.",
                    start_index=np.int32(base))
        c.set_auto_mask(False)
        c[:] = conn
        depth = 50.0 + 40.0 * np.sin(np.radians(6 * fx)) * np.cos(np.radians(9 * fy))
        add_var(ds, "depth", "f8", ("nMesh2_face",), depth, mesh="mesh2", location="face",
                coordinates="mesh2_face_x mesh2_face_y", standard_name="sea_floor_depth_below_geoid",
                units="m")
        if one_based:
            return
        add_var(ds, "time", "f8", ("time",), [0.0, 6.0], standard_name="time",
                units="hours since 2020-01-01", calendar="gregorian")
        temp = np.array([15.0 + 0.2 * fy + 0.1 * fx + t for t in range(2)])
        temp = np.ma.masked_array(temp, mask=np.zeros_like(temp, dtype=bool))
        temp.mask[1, 7] = True
        add_var(ds, "temp", "f4", ("time", "nMesh2_face"), temp, fill=np.float32(-9999.0), mesh="mesh2",
                location="face", coordinates="mesh2_face_x mesh2_face_y",
                standard_name="sea_water_temperature", units="degC")
        add_var(ds, "elev", "f8", ("nMesh2_node",), 100.0 + 3.0 * lon - 2.0 * lat, mesh="mesh2",
                location="node", coordinates="mesh2_node_x mesh2_node_y", long_name="elevation",
                units="m")


def icon_salinity(clon, clat, ntime=2, ndepth=3):
    s = np.empty((ntime, ndepth, len(clon)))
    for t in range(ntime):
        for k in range(ndepth):
            s[t, k] = 35.0 + np.cos(clat) * np.sin(2.0 * clon) + k + 0.5 * t
    s = np.ma.masked_array(s, mask=np.zeros_like(s, dtype=bool))
    s.mask[:, 2, np.degrees(clat) > 60.0] = True
    return s


def write_icon_grid(path, level=2):
    _, tris, _, vlon, vlat, clon, clat = icon_mesh(level)
    with netCDF4.Dataset(path, "w", format="NETCDF4") as ds:
        ds.title = "ICON grid description"
        ds.grid_mapping_name = "lat_long_on_sphere"
        ds.uuidOfHGrid = UUID
        ds.number_of_grid_used = np.int32(1)
        ds.createDimension("cell", len(tris))
        ds.createDimension("vertex", len(vlon))
        ds.createDimension("nv", 3)
        add_var(ds, "clon", "f8", ("cell",), clon, long_name="center longitude", units="radian",
                standard_name="longitude", bounds="clon_vertices")
        add_var(ds, "clat", "f8", ("cell",), clat, long_name="center latitude", units="radian",
                standard_name="latitude", bounds="clat_vertices")
        add_var(ds, "clon_vertices", "f8", ("cell", "nv"), vlon[tris], units="radian")
        add_var(ds, "clat_vertices", "f8", ("cell", "nv"), vlat[tris], units="radian")
        add_var(ds, "vlon", "f8", ("vertex",), vlon, long_name="vertex longitude", units="radian")
        add_var(ds, "vlat", "f8", ("vertex",), vlat, long_name="vertex latitude", units="radian")
        add_var(ds, "vertex_of_cell", "i4", ("nv", "cell"), tris.T + 1,
                long_name="vertices of each cell", cdi="ignore")


def write_icon_data(path, coords=True, ncells=None, units="radian", level=2, uuid=UUID):
    _, tris, _, vlon, vlat, clon, clat = icon_mesh(level)
    s = icon_salinity(clon, clat)
    n = len(clon) if ncells is None else ncells
    with netCDF4.Dataset(path, "w", format="NETCDF4") as ds:
        ds.CDI = "Climate Data Interface version 2.4.0 (https://mpimet.mpg.de/cdi)"
        ds.Conventions = "CF-1.6"
        ds.number_of_grid_used = np.int32(1)
        ds.uuidOfHGrid = uuid
        ds.createDimension("time", None)
        ds.createDimension("ncells", n)
        if coords:
            ds.createDimension("vertices", 3)
        ds.createDimension("depth", 3)
        add_var(ds, "time", "f8", ("time",), [0.0, 86400.0], standard_name="time",
                units="seconds since 2020-01-01 00:00:00", calendar="proleptic_gregorian", axis="T")
        if coords:
            add_var(ds, "clon", "f8", ("ncells",), clon, standard_name="longitude",
                    long_name="center longitude", units=units, bounds="clon_bnds")
            add_var(ds, "clon_bnds", "f8", ("ncells", "vertices"), vlon[tris], units=units)
            add_var(ds, "clat", "f8", ("ncells",), clat, standard_name="latitude",
                    long_name="center latitude", units=units, bounds="clat_bnds")
            add_var(ds, "clat_bnds", "f8", ("ncells", "vertices"), vlat[tris], units=units)
        add_var(ds, "depth", "f8", ("depth",), [5.0, 15.0, 25.0], standard_name="depth",
                long_name="depth_below_sea", units="m", positive="down", axis="Z")
        attrs = dict(standard_name="sea_water_salinity", long_name="salinity", units="psu",
                     CDI_grid_type="unstructured", number_of_grid_in_reference=np.int32(1),
                     missing_value=np.float32(-9e33))
        if coords:
            attrs["coordinates"] = "clat clon"
        add_var(ds, "S", "f4", ("time", "depth", "ncells"), s[:, :, :n], fill=np.float32(-9e33), **attrs)


def write_mpas(grid_path, data_path, level=2):
    xyz, tris, centres, voc = mpas_mesh(level)
    nc, nv = len(xyz), len(centres)
    lon_c, lat_c = to_lonlat(xyz)
    lon_v, lat_v = to_lonlat(centres)
    lon_c, lon_v = lon_0_2pi(lon_c), lon_0_2pi(lon_v)
    nedges = np.array([len(v) for v in voc], dtype=np.int32)
    von = np.zeros((nc, 6), dtype=np.int32)
    for c, v in enumerate(voc):
        von[c, :len(v)] = np.array(v) + 1
    with netCDF4.Dataset(grid_path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.on_a_sphere = "YES"
        ds.sphere_radius = 1.0
        ds.is_periodic = "NO"
        ds.mesh_spec = "1.0"
        ds.file_id = f"hdrvis-icosahedral-{level}"
        for name, n in (("nCells", nc), ("nVertices", nv), ("maxEdges", 6), ("vertexDegree", 3)):
            ds.createDimension(name, n)
        add_var(ds, "latCell", "f8", ("nCells",), lat_c, units="radians", long_name="Latitude of cells")
        add_var(ds, "lonCell", "f8", ("nCells",), lon_c, units="radians", long_name="Longitude of cells")
        for k, axis in enumerate("xyz"):
            add_var(ds, f"{axis}Cell", "f8", ("nCells",), xyz[:, k], units="unitless")
        add_var(ds, "latVertex", "f8", ("nVertices",), lat_v, units="radians",
                long_name="Latitude of vertices")
        add_var(ds, "lonVertex", "f8", ("nVertices",), lon_v, units="radians",
                long_name="Longitude of vertices")
        for k, axis in enumerate("xyz"):
            add_var(ds, f"{axis}Vertex", "f8", ("nVertices",), centres[:, k], units="unitless")
        add_var(ds, "indexToCellID", "i4", ("nCells",), np.arange(1, nc + 1, dtype=np.int32))
        add_var(ds, "indexToVertexID", "i4", ("nVertices",), np.arange(1, nv + 1, dtype=np.int32))
        add_var(ds, "nEdgesOnCell", "i4", ("nCells",), nedges, units="unitless")
        add_var(ds, "verticesOnCell", "i4", ("nCells", "maxEdges"), von, units="unitless")
        add_var(ds, "cellsOnVertex", "i4", ("nVertices", "vertexDegree"), tris + 1, units="unitless")
    lon_deg = wrap180(np.degrees(lon_v))
    lat_deg = np.degrees(lat_v)
    with netCDF4.Dataset(data_path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.on_a_sphere = "YES"
        ds.sphere_radius = 1.0
        ds.model_name = "mpas"
        ds.core_name = "atmosphere"
        for name, n in (("Time", None), ("nCells", nc), ("nVertLevels", 2), ("nVertices", nv),
                        ("StrLen", 64)):
            ds.createDimension(name, n)
        xt = ds.createVariable("xtime", "S1", ("Time", "StrLen"))
        xt[:] = netCDF4.stringtochar(np.array(["2020-01-01_00:00:00", "2020-01-01_06:00:00"], dtype="S64"))
        temp = np.empty((2, nc, 2))
        for t in range(2):
            for k in range(2):
                temp[t, :, k] = 280.0 + 20.0 * np.cos(lat_c) + np.sin(lon_c) - 5.0 * k + t
        add_var(ds, "temperature", "f8", ("Time", "nCells", "nVertLevels"), temp, units="K",
                long_name="temperature")
        vort = np.array([1.0 + 0.01 * lon_deg + 0.02 * lat_deg + 0.5 * t for t in range(2)])
        add_var(ds, "vorticity", "f8", ("Time", "nVertices"), vort, units="s^-1",
                long_name="Relative vorticity at vertices")


def scrip_corners():
    nx, ny = 12, 8
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    lon = 100.0 + 2.0 * i + 0.25 * (j - ny / 2)
    lat = -10.0 + 2.0 * j + 0.01 * (i - nx / 2) ** 2
    clon = np.empty((nx * ny, 4))
    clat = np.empty((nx * ny, 4))
    for jj in range(ny):
        for ii in range(nx):
            n = jj * nx + ii
            idx = [(jj, ii), (jj, ii + 1), (jj + 1, ii + 1), (jj + 1, ii)]
            clon[n] = [lon[p] for p in idx]
            clat[n] = [lat[p] for p in idx]
            if not is_convex(clon[n], clat[n]) or signed_area2(clon[n], clat[n]) <= 0:
                raise AssertionError(f"scrip cell {n} is not convex and counter-clockwise")
    return nx, ny, clon, clat


def write_scrip(path, radians=False):
    nx, ny, clon, clat = scrip_corners()
    conv = np.radians if radians else (lambda a: a)
    units = "radians" if radians else "degrees"
    with netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC") as ds:
        ds.title = "hdrvis test grid: sheared regional quadrilaterals (SCRIP)"
        for name, n in (("grid_size", nx * ny), ("grid_corners", 4), ("grid_rank", 2)):
            ds.createDimension(name, n)
        add_var(ds, "grid_dims", "i4", ("grid_rank",), [nx, ny])
        add_var(ds, "grid_center_lat", "f8", ("grid_size",), conv(clat.mean(axis=1)), units=units)
        add_var(ds, "grid_center_lon", "f8", ("grid_size",), conv(clon.mean(axis=1)), units=units)
        add_var(ds, "grid_imask", "i4", ("grid_size",), np.ones(nx * ny, dtype=np.int32), units="unitless")
        add_var(ds, "grid_corner_lat", "f8", ("grid_size", "grid_corners"), conv(clat), units=units)
        add_var(ds, "grid_corner_lon", "f8", ("grid_size", "grid_corners"), conv(clon), units=units)


def write_scrip_data(path):
    _, _, clon, clat = scrip_corners()
    lon, lat = clon.mean(axis=1), clat.mean(axis=1)
    with netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.createDimension("ncol", len(lon))
        add_var(ds, "T850", "f4", ("ncol",), 270.0 + 0.5 * lat + np.sin(np.radians(10.0 * lon)),
                units="K", long_name="Temperature at 850 mbar pressure surface")


def fvcom_mesh():
    return triangle_patch(-70.0, -69.0, 7, 41.0, 42.0, 7, 11, clockwise=True)


def adcirc_mesh():
    return triangle_patch(-90.0, -88.5, 8, 28.5, 29.7, 6, 23, clockwise=False)


def write_fvcom(path, mesh=None, depth=None):
    """fvcom.nc; mesh: (lon, lat, triangles) of another patch (default fvcom_mesh(), whose
    triangles are clockwise, as FVCOM stores them), depth: its h(node) (default a plane)."""
    lon, lat, tris = fvcom_mesh() if mesh is None else mesh
    tris = np.array(tris)
    lonc, latc = lon[tris].mean(axis=1), lat[tris].mean(axis=1)
    with netCDF4.Dataset(path, "w", format="NETCDF4_CLASSIC") as ds:
        ds.title = "hdrvis test case"
        ds.institution = "School for Marine Science and Technology"
        ds.source = "FVCOM_4.3"
        ds.Conventions = "CF-1.0"
        ds.CoordinateSystem = "GeoReferenced"
        ds.CoordinateProjection = "init=WGS84"
        for name, n in (("nele", len(tris)), ("node", len(lon)), ("siglay", 2), ("three", 3),
                        ("time", None)):
            ds.createDimension(name, n)
        add_var(ds, "lon", "f8", ("node",), lon, long_name="nodal longitude", standard_name="longitude",
                units="degrees_east")
        add_var(ds, "lat", "f8", ("node",), lat, long_name="nodal latitude", standard_name="latitude",
                units="degrees_north")
        add_var(ds, "lonc", "f8", ("nele",), lonc, long_name="zonal longitude", standard_name="longitude",
                units="degrees_east")
        add_var(ds, "latc", "f8", ("nele",), latc, long_name="zonal latitude", standard_name="latitude",
                units="degrees_north")
        if depth is None:
            depth = 20.0 + 10.0 * (lat - 41.0) + 5.0 * (lon + 70.0)
        add_var(ds, "h", "f8", ("node",), depth,
                long_name="Bathymetry", standard_name="sea_floor_depth_below_geoid", units="m",
                positive="down", grid="Bathymetry_Mesh", coordinates="lat lon", type="data")
        add_var(ds, "nv", "i4", ("three", "nele"), tris.T + 1, long_name="nodes surrounding element")
        add_var(ds, "time", "f4", ("time",), [58849.0, 58849.125], long_name="time",
                units="days since 1858-11-17 00:00:00", format="modified julian day (MJD)",
                time_zone="UTC")
        zeta = np.array([0.5 + 0.01 * lon - 0.02 * lat + 0.1 * t for t in range(2)])
        add_var(ds, "zeta", "f8", ("time", "node"), zeta, long_name="Water Surface Elevation",
                units="meters", positive="up", standard_name="sea_surface_height_above_geoid",
                grid="SSH_Mesh", coordinates="time lat lon", type="data", location="node")
        temp = np.array([[10.0 + 2.0 * (latc - 41.0) - k + 0.5 * t for k in range(2)] for t in range(2)])
        add_var(ds, "temp", "f4", ("time", "siglay", "nele"), temp, long_name="temperature",
                standard_name="sea_water_temperature", units="degrees_C", grid="fvcom_grid",
                coordinates="time siglay latc lonc", type="data", location="face")


ADCIRC_DRY_NODE = 30


def write_adcirc(path):
    lon, lat, tris = adcirc_mesh()
    tris = np.array(tris)
    with netCDF4.Dataset(path, "w", format="NETCDF4_CLASSIC") as ds:
        ds.model_domain = "hdrvis test mesh"
        ds.version = "v55.01"
        ds.grid_type = "Triangular"
        ds.description = "ADCIRC fort.63.nc style water surface elevation"
        ds.agrid = "hdrvis test mesh"
        ds.rundes = "hdrvis test"
        ds.runid = "1"
        ds.title = "ADCIRC"
        ds.institution = "hdrvis"
        ds.source = "ADCIRC"
        ds.history = "written by tests/python/write_mesh_cases.py"
        ds.Conventions = "CF-1.0"
        for name, n in (("time", None), ("node", len(lon)), ("nele", len(tris)), ("nvertex", 3)):
            ds.createDimension(name, n)
        add_var(ds, "time", "f8", ("time",), [0.0, 3600.0], long_name="model time", standard_name="time",
                units="seconds since 2020-01-01 00:00:00", base_date="2020-01-01 00:00:00")
        add_var(ds, "x", "f8", ("node",), lon, long_name="longitude", standard_name="longitude",
                units="degrees_east", positive="east")
        add_var(ds, "y", "f8", ("node",), lat, long_name="latitude", standard_name="latitude",
                units="degrees_north", positive="north")
        add_var(ds, "element", "i4", ("nele", "nvertex"), tris + 1, long_name="element",
                units="nondimensional")
        add_var(ds, "depth", "f8", ("node",), 3.0 + 4.0 * (29.7 - lat) + 2.0 * (lon + 90.0),
                long_name="distance below geoid", standard_name="depth below geoid",
                coordinates="time y x", units="m")
        zeta = np.array([0.5 + 0.01 * lon - 0.02 * lat + 0.1 * t for t in range(2)])
        zeta = np.ma.masked_array(zeta, mask=np.zeros_like(zeta, dtype=bool))
        zeta.mask[1, ADCIRC_DRY_NODE] = True
        add_var(ds, "zeta", "f8", ("time", "node"), zeta, fill=-99999.0,
                long_name="water surface elevation above geoid", standard_name="sea_surface_height_above_geoid",
                coordinates="time y x", units="m", positive="up")


def camse_columns(n=600):
    """A quasi-uniform global set of column centres (a Fibonacci sphere, each point nudged by a
    hashed amount, so no four lie on one circle), as CAM-SE's ne-grids spread theirs."""
    k = np.arange(n) + 0.5
    lat = np.degrees(np.arcsin(1.0 - 2.0 * k / n))
    lon = (np.degrees(np.pi * (1.0 + 5.0 ** 0.5) * k)) % 360.0
    lat = lat + np.array([0.3 * (hash01(i, 1, 7) - 0.5) for i in range(n)])
    lon = (lon + np.array([0.3 * (hash01(i, 2, 7) - 0.5) for i in range(n)])) % 360.0
    return lon, np.clip(lat, -89.9, 89.9)


def write_camse(path):
    """CAM-SE history output on its native grid: columns `ncol` with only their centres,
    lat(ncol) and lon(ncol) in degrees (lon in [0, 360)), area(ncol), T850(time, ncol) and the
    exactly linear lin(ncol) = 2 + 0.01 lon + 0.03 lat."""
    lon, lat = camse_columns()
    with netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.createDimension("ncol", len(lon))
        ds.createDimension("time", None)
        ds.ne = 4
        add_var(ds, "time", "f8", ("time",), [0.0, 1.0], units="days since 2000-01-01 00:00:00",
                calendar="noleap")
        add_var(ds, "lat", "f8", ("ncol",), lat, long_name="latitude", units="degrees_north")
        add_var(ds, "lon", "f8", ("ncol",), lon, long_name="longitude", units="degrees_east")
        add_var(ds, "area", "f8", ("ncol",), np.full(len(lon), 4.0 * np.pi / len(lon)),
                long_name="gll grid areas")
        t = np.array([250.0 + 30.0 * np.cos(np.radians(lat)) + 3.0 * np.sin(np.radians(2 * lon)) + s
                      for s in (0.0, 1.0)])
        add_var(ds, "T850", "f4", ("time", "ncol"), t, units="K", long_name="Temperature at 850 mbar pressure surface")
        add_var(ds, "lin", "f8", ("ncol",), 2.0 + 0.01 * lon + 0.03 * lat, units="1")


# -- reading (the reference's own reader of each convention) ---------------------------------------


class Mesh:
    """cells: for each cell, (lon_deg, lat_deg, node indices or None); face_dims / node_dims:
    the names of the dimensions of face and node data."""

    def __init__(self, kind, cells, face_dims, node_dims=(), n_nodes=0):
        self.kind, self.cells, self.face_dims, self.node_dims = kind, cells, face_dims, node_dims
        self.n_nodes = n_nodes


def degrees(values, units, what):
    u = (units or "").strip().lower()
    if u.startswith("rad"):
        # In double precision: float32 radians converted in float32 would move nodes by 1e-6.
        return np.degrees(np.asarray(values, dtype=float))
    if u.startswith("deg"):
        return np.asarray(values, dtype=float)
    raise Fail(f"{what}: units {units!r} are neither degrees nor radians")


def raw(var):
    var.set_auto_maskandscale(False)
    return np.asarray(var[...])


def cells_from_nodes(lon, lat, conn, valid):
    n = len(lon)
    cells = []
    for k in range(conn.shape[0]):
        idx = conn[k][valid[k]]
        if len(idx) < 3:
            raise Fail(f"cell {k} has {len(idx)} valid nodes")
        if idx.min() < 0 or idx.max() >= n:
            raise Fail(f"cell {k} refers to node {int(idx.max() if idx.max() >= n else idx.min())} of {n}")
        cells.append((lon[idx], lat[idx], idx))
    return cells


def load_mesh(ds):
    names = ds.variables
    topo = [v for v in names.values() if getattr(v, "cf_role", None) == "mesh_topology"]
    if topo:
        m = topo[0]
        xname, yname = m.node_coordinates.split()
        x, y = ds[xname], ds[yname]
        lon = degrees(raw(x), getattr(x, "units", None), xname)
        lat = degrees(raw(y), getattr(y, "units", None), yname)
        cv = ds[m.face_node_connectivity]
        conn = raw(cv).astype(np.int64)
        fill = getattr(cv, "_FillValue", None)
        valid = np.ones(conn.shape, dtype=bool) if fill is None else conn != int(fill)
        conn = conn - int(getattr(cv, "start_index", 0))
        face_dim = getattr(m, "face_dimension", cv.dimensions[0])
        return Mesh("ugrid", cells_from_nodes(lon, lat, conn, valid), (face_dim,), (x.dimensions[0],), len(lon))
    if "clon" in names and "clat" in names and hasattr(ds["clon"], "bounds"):
        lon_b, lat_b = ds[ds["clon"].bounds], ds[ds["clat"].bounds]
        # CF: bounds without units have their coordinate's.
        lon = degrees(raw(lon_b), getattr(lon_b, "units", getattr(ds["clon"], "units", None)), lon_b.name)
        lat = degrees(raw(lat_b), getattr(lat_b, "units", getattr(ds["clat"], "units", None)), lat_b.name)
        return Mesh("icon", [(lon[k], lat[k], None) for k in range(len(lon))], ("ncells", "cell"))
    if "verticesOnCell" in names:
        lon = degrees(raw(ds["lonVertex"]), ds["lonVertex"].units, "lonVertex")
        lat = degrees(raw(ds["latVertex"]), ds["latVertex"].units, "latVertex")
        von = raw(ds["verticesOnCell"]).astype(np.int64) - 1
        nedges = raw(ds["nEdgesOnCell"]).astype(np.int64)
        valid = np.arange(von.shape[1])[None, :] < nedges[:, None]
        return Mesh("mpas", cells_from_nodes(lon, lat, von, valid), ("nCells",), ("nVertices",), len(lon))
    if "grid_corner_lat" in names:
        lon_v, lat_v = ds["grid_corner_lon"], ds["grid_corner_lat"]
        lon = degrees(raw(lon_v), getattr(lon_v, "units", None), "grid_corner_lon")
        lat = degrees(raw(lat_v), getattr(lat_v, "units", None), "grid_corner_lat")
        return Mesh("scrip", [(lon[k], lat[k], None) for k in range(len(lon))], ("grid_size", "ncol"))
    if "nv" in names and "lonc" in names:
        lon = degrees(raw(ds["lon"]), ds["lon"].units, "lon")
        lat = degrees(raw(ds["lat"]), ds["lat"].units, "lat")
        conn = raw(ds["nv"]).astype(np.int64).T - 1
        return Mesh("fvcom", cells_from_nodes(lon, lat, conn, np.ones(conn.shape, bool)), ("nele",), ("node",),
                    len(lon))
    if "element" in names and "x" in names:
        lon = degrees(raw(ds["x"]), ds["x"].units, "x")
        lat = degrees(raw(ds["y"]), ds["y"].units, "y")
        conn = raw(ds["element"]).astype(np.int64) - 1
        return Mesh("adcirc", cells_from_nodes(lon, lat, conn, np.ones(conn.shape, bool)), ("nele",), ("node",),
                    len(lon))
    if "ncol" in ds.dimensions and "lat" in names and "lon" in names and ds["lat"].dimensions == ("ncol",):
        from scipy.spatial import ConvexHull
        lon = degrees(raw(ds["lon"]), ds["lon"].units, "lon")
        lat = degrees(raw(ds["lat"]), ds["lat"].units, "lat")
        xyz = np.stack([np.cos(np.radians(lat)) * np.cos(np.radians(lon)),
                        np.cos(np.radians(lat)) * np.sin(np.radians(lon)), np.sin(np.radians(lat))], axis=1)
        # The sphere's Delaunay triangles are its centres' convex hull's faces (qhull).
        tris = ConvexHull(xyz).simplices.astype(np.int64)
        return Mesh("columns", cells_from_nodes(lon, lat, tris, np.ones(tris.shape, bool)), (), ("ncol",), len(lon))
    raise Fail("no mesh found")


def mesh_from_spec(ds, spec):
    """A mesh read as `spec` says (a real file's layout, as a reader of its header states it, so
    the reference needs no convention rules of its own): "nodes" (node longitudes and latitudes
    and a connectivity, faces along its first axis unless "faces_first" is false, 0- or 1-based
    by its start_index attribute, else "base"; its _FillValue marks absent corners), "corners"
    (each cell's corner longitudes and latitudes, cells along the first axis) or "columns"
    (centres only: their sphere's Delaunay triangles). Coordinates without units are degrees."""
    def coord(name):
        v = ds[name]
        units = getattr(v, "units", None)
        return degrees(raw(v), units, name) if units is not None else raw(v).astype(float)

    kind = spec["kind"]
    lon, lat = coord(spec["lon"]), coord(spec["lat"])
    face_dims, node_dims = tuple(spec.get("face_dims", ())), tuple(spec.get("node_dims", ()))
    if kind == "nodes":
        cv = ds[spec["faces"]]
        conn = raw(cv).astype(np.int64)
        if not spec.get("faces_first", True):
            conn = conn.T
        fill = getattr(cv, "_FillValue", None)
        valid = np.ones(conn.shape, dtype=bool) if fill is None else conn != int(fill)
        conn = conn - int(getattr(cv, "start_index", spec.get("base", 0)))
        return Mesh("spec", cells_from_nodes(lon, lat, conn, valid), face_dims, node_dims, len(lon))
    if kind == "corners":
        return Mesh("spec", [(lon[k], lat[k], None) for k in range(len(lon))], face_dims)
    if kind == "columns":
        from scipy.spatial import ConvexHull
        xyz = np.stack([np.cos(np.radians(lat)) * np.cos(np.radians(lon)),
                        np.cos(np.radians(lat)) * np.sin(np.radians(lon)), np.sin(np.radians(lat))], axis=1)
        tris = ConvexHull(xyz).simplices.astype(np.int64)
        return Mesh("spec", cells_from_nodes(lon, lat, tris, np.ones(tris.shape, bool)), (), node_dims, len(lon))
    raise Fail(f"unknown mesh kind {kind!r}")


def read_field(ds, mesh, name, index):
    """The variable's values along its mesh dimension (float, NaN where missing) and whether
    they are on faces ("face") or nodes ("node")."""
    if name not in ds.variables:
        raise Fail(f"no variable {name}")
    var = ds[name]
    var.set_auto_maskandscale(True)
    loc = None
    for k, dim in enumerate(var.dimensions):
        if dim in mesh.face_dims:
            loc, axis, expect = "face", k, len(mesh.cells)
        elif dim in mesh.node_dims:
            loc, axis, expect = "node", k, mesh.n_nodes
    if loc is None:
        raise Fail(f"{name} has no mesh dimension ({var.dimensions})")
    unknown = set(index) - set(var.dimensions)
    if unknown:
        raise Fail(f"index names {sorted(unknown)} not among {var.dimensions}")
    sel = []
    for k, (dim, n) in enumerate(zip(var.dimensions, var.shape)):
        if k == axis:
            sel.append(slice(None))
        elif dim in index:
            sel.append(int(index[dim]))
        elif n == 1:
            sel.append(0)
        else:
            raise Fail(f"no index for dimension {dim} of {name}")
    values = np.ma.filled(np.ma.asarray(var[tuple(sel)]).astype(float), np.nan)
    if values.shape != (expect,):
        raise Fail(f"{name}: {values.shape[0]} values along {var.dimensions[axis]}, the mesh has {expect}")
    return values, loc


# -- the geometry ----------------------------------------------------------------------------------


def unwrap_to(lon, ref):
    """lon shifted by a multiple of 360 into [ref - 180, ref + 180)."""
    return lon - 360.0 * math.floor((lon - ref + 180.0) / 360.0)


def cell_polygon(lons, lats, vals):
    """The cell's polygon in the (longitude, latitude) plane with the pole and closing rules:
    (xs, ys, vs) with vs each vertex's value (node data; NaN-free only where all are), or None
    for a cell whose vertices are all at a pole."""
    lons, lats, vals = [float(v) for v in lons], [float(v) for v in lats], [float(v) for v in vals]
    n = len(lons)
    pole = [abs(la) >= 90.0 - POLE_TOL for la in lats]
    order = [i for i in range(n) if not pole[i]]
    if not order:
        return None
    u = {}
    prev = None
    for i in order:
        u[i] = lons[i] if prev is None else unwrap_to(lons[i], prev)
        prev = u[i]
    xs, ys, vs = [], [], []
    for i in range(n):
        if not pole[i]:
            xs.append(u[i]), ys.append(lats[i]), vs.append(vals[i])
            continue
        p = next(j for j in [(i - d) % n for d in range(1, n + 1)] if not pole[j])
        q = next(j for j in [(i + d) % n for d in range(1, n + 1)] if not pole[j])
        plat = 90.0 if lats[i] > 0 else -90.0
        xs += [u[p], u[q]]
        ys += [plat, plat]
        vs += [vals[i], vals[i]]
    first, last = order[0], order[-1]
    close = unwrap_to(lons[first], u[last])
    if abs(abs(close - u[first]) - 360.0) <= RING_TOL:
        plat = 90.0 if sum(lats) / n > 0 else -90.0
        mean = sum(vals) / n
        xs += [close, close, u[first]]
        ys += [lats[first], plat, plat]
        vs += [vals[first], mean, mean]
        return np.array(xs), np.array(ys), np.array(vs), True
    return np.array(xs), np.array(ys), np.array(vs), False


def locate(polygons, lon, lat):
    """For points (lon, lat), by brute force over every polygon and shift: edge (bool: within
    EDGE_TOL of an edge or vertex of some cell), cell (first containing cell or -1), shift of
    that hit, count (number of (cell, shift) hits)."""
    npt = len(lon)
    edge = np.zeros(npt, dtype=bool)
    cell = np.full(npt, -1)
    shift = np.zeros(npt)
    count = np.zeros(npt, dtype=int)
    tol2 = EDGE_TOL * EDGE_TOL
    for c, poly in enumerate(polygons):
        if poly is None:
            continue
        xs, ys = poly[0], poly[1]
        idx0 = np.nonzero((lat >= ys.min() - EDGE_TOL) & (lat <= ys.max() + EDGE_TOL))[0]
        if not len(idx0):
            continue
        m = len(xs)
        for s in SHIFTS:
            px = lon[idx0] + s
            keep = (px >= xs.min() - EDGE_TOL) & (px <= xs.max() + EDGE_TOL)
            idx, px = idx0[keep], px[keep]
            if not len(idx):
                continue
            py = lat[idx]
            near = np.zeros(len(idx), dtype=bool)
            inside = np.zeros(len(idx), dtype=bool)
            for k in range(m):
                x1, y1, x2, y2 = xs[k], ys[k], xs[(k + 1) % m], ys[(k + 1) % m]
                dx, dy = x2 - x1, y2 - y1
                l2 = dx * dx + dy * dy
                t = np.zeros(len(idx)) if l2 == 0 else np.clip(((px - x1) * dx + (py - y1) * dy) / l2, 0.0, 1.0)
                near |= (px - x1 - t * dx) ** 2 + (py - y1 - t * dy) ** 2 <= tol2
                crosses = (y1 > py) != (y2 > py)
                if dy != 0:
                    xint = x1 + (py - y1) * dx / dy
                    inside ^= crosses & (px < xint)
            edge[idx[near]] = True
            hit = inside & ~near
            count[idx[hit]] += 1
            new = hit & (cell[idx] < 0)
            cell[idx[new]] = c
            shift[idx[new]] = s
    return edge, cell, shift, count


def triangles_of(poly):
    """Node data's triangles of a cell: the fan from its first vertex, or for a ring round a
    pole one trapezoid per ring edge down to the pole (two triangles each; the pole takes the
    mean of the ring's values)."""
    xs, ys, vs, cap = poly
    if not cap:
        return [((xs[0], ys[0], vs[0]), (xs[k], ys[k], vs[k]), (xs[k + 1], ys[k + 1], vs[k + 1]))
                for k in range(1, len(xs) - 1)]
    own = len(xs) - 2  # the ring's vertices and the first one repeated across the seam
    plat, mean = ys[-1], vs[-1]
    out = []
    for k in range(own - 1):
        a, b = (xs[k], ys[k], vs[k]), (xs[k + 1], ys[k + 1], vs[k + 1])
        if a[0] > b[0]:  # west to east: the diagonal does not depend on the ring's direction
            a, b = b, a
        pa, pb = (a[0], plat, mean), (b[0], plat, mean)
        out += [(a, b, pb), (a, pb, pa)]
    return out


def fan_value(poly, px, py):
    """Barycentric value over the first of the cell's triangles holding (px, py), or None."""
    for (ax, ay, va), (bx, by, vb), (cx, cy, vc) in triangles_of(poly):
        det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
        if det == 0:
            continue
        wb = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / det
        wc = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / det
        wa = 1.0 - wb - wc
        if min(wa, wb, wc) >= -BARY_TOL:
            return wa * va + wb * vb + wc * vc
    return None


def sample_points(mesh, values, loc, lon, lat):
    """The reference value at each point: float, None or "edge"."""
    polys = []
    for lons, lats, nodes in mesh.cells:
        if loc == "node":
            vals = values[nodes]
        else:
            vals = np.zeros(len(lons))
        polys.append(cell_polygon(lons, lats, vals))
    if loc == "node":
        good = [bool(np.all(np.isfinite(values[nodes]))) for _, _, nodes in mesh.cells]
    else:
        good = [bool(np.isfinite(v)) for v in values]
    lon, lat = np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)
    # Cells with missing data count as no cell; the edges of every cell are ambiguous.
    edge, _, _, _ = locate(polys, lon, lat)
    live = [p if g else None for p, g in zip(polys, good)]
    _, cell, shift, count = locate(live, lon, lat)
    out = []
    for n in range(len(lon)):
        if edge[n]:
            out.append("edge")
        elif count[n] > 1:
            # Two cells overlap here in the (longitude, latitude) plane (a triangle near a
            # pole whose straight edges cross the cap of another): either may be drawn.
            out.append("overlap")
        elif cell[n] < 0:
            out.append(None)
        elif loc == "face":
            out.append(float(values[cell[n]]))
        else:
            v = fan_value(polys[cell[n]], lon[n] + shift[n], lat[n])
            out.append(None if v is None else float(v))
    return out


def open_request(out, request):
    path = os.path.join(out, request["file"])
    grid = request.get("grid")
    spec = request.get("mesh")
    with netCDF4.Dataset(path) as ds:
        if grid:
            with netCDF4.Dataset(os.path.join(out, grid)) as gds:
                mesh = mesh_from_spec(gds, spec) if spec else load_mesh(gds)
        else:
            mesh = mesh_from_spec(ds, spec) if spec else load_mesh(ds)
        values, loc = read_field(ds, mesh, request["variable"], request.get("index") or {})
    return mesh, values, loc


def sample(out, request):
    mesh, values, loc = open_request(out, request)
    if "points" in request:
        # Points anywhere (a globe's pixels): [[lon, lat], ...].
        pts = np.asarray(request["points"], dtype=float).reshape(-1, 2)
        return sample_points(mesh, values, loc, pts[:, 0], pts[:, 1])
    lon_axis = np.asarray(request["lon"], dtype=float)
    lat_axis = np.asarray(request["lat"], dtype=float)
    lat, lon = np.meshgrid(lat_axis, lon_axis, indexing="ij")
    return sample_points(mesh, values, loc, lon.ravel(), lat.ravel())


# -- write ----------------------------------------------------------------------------------------


def describe(out, name, kind, grid=None, faces_vars=(), node_vars=(), linear=None, missing=None, fault=None,
             notes=""):
    path = os.path.join(out, name)
    with netCDF4.Dataset(path) as ds:
        dims = {d: len(v) for d, v in ds.dimensions.items()}
        fmt = ds.data_model
        try:
            if grid:
                with netCDF4.Dataset(os.path.join(out, grid)) as gds:
                    mesh = load_mesh(gds)
            else:
                mesh = load_mesh(ds)
            faces, nodes = len(mesh.cells), (mesh.n_nodes or None)
            face_dim = next((d for d in ds.dimensions if d in mesh.face_dims), None)
            node_dim = next((d for d in ds.dimensions if d in mesh.node_dims), None)
        except Fail:
            faces = nodes = face_dim = node_dim = None
    if fault and kind.startswith("ugrid"):
        faces, nodes, face_dim, node_dim = dims["nMesh2_face"], dims["nMesh2_node"], "nMesh2_face", "nMesh2_node"
    return {"file": name, "kind": kind, "grid": grid, "format": fmt, "dims": dims, "faces": faces,
            "nodes": nodes, "face_dim": face_dim, "node_dim": node_dim, "face_variables": list(faces_vars),
            "node_variables": list(node_vars), "linear": linear or {}, "missing": missing or {},
            "fault": fault, "notes": notes, "bytes": os.path.getsize(path)}


def write(out):
    os.makedirs(out, exist_ok=True)

    def p(name):
        return os.path.join(out, name)

    write_ugrid(p("ugrid.nc"))
    write_ugrid(p("ugrid_1based.nc"), one_based=True)
    write_icon_grid(p("icon_grid.nc"))
    write_icon_data(p("icon_data.nc"))
    write_icon_data(p("icon_data_only.nc"), coords=False)
    write_mpas(p("mpas_grid.nc"), p("mpas_data.nc"))
    write_scrip(p("scrip_grid.nc"))
    write_scrip(p("scrip_grid_radians.nc"), radians=True)
    write_scrip_data(p("scrip_data.nc"))
    write_fvcom(p("fvcom.nc"))
    write_adcirc(p("adcirc.nc"))
    write_camse(p("camse.nc"))
    write_ugrid(p("bad_index.nc"), fault="index")
    write_ugrid(p("bad_polygon.nc"), fault="polygon")
    write_icon_data(p("bad_units.nc"), units="furlongs")
    write_icon_data(p("icon_data_mismatch.nc"), coords=False, ncells=319)
    write_icon_data(p("icon_data_other_grid.nc"), coords=False, uuid=OTHER_UUID)
    icon_missing = {"S": "_FillValue -9e33 at depth index 2 where clat > 60 degrees"}
    mpas_notes = "12 pentagons, 150 hexagons; the pole cells' vertices are on one latitude"
    cases = [
        describe(out, "ugrid.nc", "ugrid", faces_vars=["depth", "temp"], node_vars=["elev"],
                 linear={"elev": "100 + 3*lon - 2*lat"}, missing={"temp": "face 7 at time 1 (_FillValue -9999)"},
                 notes="90 quads + 60 triangles, counter-clockwise, start_index 0, _FillValue -1"),
        describe(out, "ugrid_1based.nc", "ugrid", faces_vars=["depth"], notes="start_index 1, _FillValue 999999"),
        describe(out, "icon_grid.nc", "icon_grid", notes="320 triangles; longitudes in [-pi, pi]"),
        describe(out, "icon_data.nc", "icon", faces_vars=["S"], missing=icon_missing,
                 notes="self-contained: clon/clat with bounds clon_bnds/clat_bnds (CDI's names)"),
        describe(out, "icon_data_only.nc", "icon", grid="icon_grid.nc", faces_vars=["S"], missing=icon_missing,
                 notes="no coordinates: read with icon_grid.nc (dim ncells there is cell)"),
        describe(out, "mpas_grid.nc", "mpas_grid", notes=mpas_notes),
        describe(out, "mpas_data.nc", "mpas", grid="mpas_grid.nc", faces_vars=["temperature"],
                 node_vars=["vorticity"],
                 linear={"vorticity": "1 + 0.01*lon + 0.02*lat + 0.5*Time, lon of the vertex in [-180, 180)"},
                 notes="no geometry; temperature(Time, nCells, nVertLevels)"),
        describe(out, "scrip_grid.nc", "scrip_grid", notes="units degrees"),
        describe(out, "scrip_grid_radians.nc", "scrip_grid", notes="units radians"),
        describe(out, "scrip_data.nc", "scrip", grid="scrip_grid.nc", faces_vars=["T850"],
                 notes="T850(ncol); also readable with scrip_grid_radians.nc"),
        describe(out, "fvcom.nc", "fvcom", faces_vars=["temp"], node_vars=["zeta"],
                 linear={"zeta": "0.5 + 0.01*lon - 0.02*lat + 0.1*time"},
                 notes="nv(three, nele) 1-based, elements clockwise"),
        describe(out, "adcirc.nc", "adcirc", node_vars=["zeta", "depth"],
                 linear={"zeta": "0.5 + 0.01*x - 0.02*y + 0.1*time"},
                 missing={"zeta": f"node {ADCIRC_DRY_NODE} (0-based) dry at time 1 (_FillValue -99999)"},
                 notes="element(nele, nvertex) 1-based, no mesh topology variable"),
        describe(out, "camse.nc", "columns", node_vars=["T850", "lin"],
                 linear={"lin": "2 + 0.01*lon + 0.03*lat, lon in [0, 360)"},
                 notes="600 columns with centres only; cells: their spherical Delaunay triangles (qhull)"),
        describe(out, "bad_index.nc", "ugrid", faces_vars=["depth", "temp"], node_vars=["elev"],
                 fault="face 10 refers to node index nodes + 5"),
        describe(out, "bad_polygon.nc", "ugrid", faces_vars=["depth", "temp"], node_vars=["elev"],
                 fault="face 10 has 2 valid nodes"),
        describe(out, "bad_units.nc", "icon", faces_vars=["S"], fault="clon/clat and bounds in units furlongs"),
        describe(out, "icon_data_mismatch.nc", "icon", grid="icon_grid.nc", faces_vars=["S"],
                 fault="ncells = 319, icon_grid.nc has 320 cells"),
        describe(out, "icon_data_other_grid.nc", "icon", grid="icon_grid.nc", faces_vars=["S"],
                 fault=f"uuidOfHGrid {OTHER_UUID}, icon_grid.nc is {UUID} (the same 320 cells)"),
    ]
    geometry = {"edge_tol_deg": EDGE_TOL, "pole_tol_deg": POLE_TOL, "ring_tol_deg": RING_TOL,
                "barycentric_tol": BARY_TOL, "shifts_deg": list(SHIFTS)}
    with open(os.path.join(out, "cases.json"), "w") as f:
        json.dump({"files": cases, "geometry": geometry}, f, indent=1)
        f.write("\n")
    print(f"{'file':24} {'kind':10} {'grid':14} {'faces':>5} {'nodes':>5} {'bytes':>7}  fault")
    for c in cases:
        print(f"{c['file']:24} {c['kind']:10} {str(c['grid'] or '-'):14} {str(c['faces']):>5} "
              f"{str(c['nodes']):>5} {c['bytes']:7}  {c['fault'] or ''}")
        if c["bytes"] > 300_000:
            print(f"FAIL {c['file']} is {c['bytes']} bytes", file=sys.stderr)
            return 1
    return 0


# -- check ----------------------------------------------------------------------------------------


def check(out):
    failures = []

    def expect(cond, msg):
        if not cond:
            failures.append(msg)

    def rng_axis(lo, hi, n, salt):
        return sorted(lo + (hi - lo) * hash01(k, 3, salt) for k in range(n))

    linear = [
        ("ugrid.nc", None, "elev", {}, (0.5, 29.5, 0.5, 19.5), lambda x, y: 100 + 3 * x - 2 * y),
        ("mpas_data.nc", "mpas_grid.nc", "vorticity", {"Time": 0}, (-140, 140, -65, 65),
         lambda x, y: 1 + 0.01 * x + 0.02 * y),
        ("mpas_data.nc", "mpas_grid.nc", "vorticity", {"Time": 1}, (-140, 140, -65, 65),
         lambda x, y: 1.5 + 0.01 * x + 0.02 * y),
        ("fvcom.nc", None, "zeta", {"time": 0}, (-69.99, -69.01, 41.01, 41.99),
         lambda x, y: 0.5 + 0.01 * x - 0.02 * y),
        ("fvcom.nc", None, "zeta", {"time": 1}, (-69.99, -69.01, 41.01, 41.99),
         lambda x, y: 0.6 + 0.01 * x - 0.02 * y),
        ("adcirc.nc", None, "zeta", {"time": 0}, (-89.99, -88.51, 28.51, 29.69),
         lambda x, y: 0.5 + 0.01 * x - 0.02 * y),
        ("adcirc.nc", None, "zeta", {"time": 1}, (-89.99, -88.51, 28.51, 29.69),
         lambda x, y: 0.6 + 0.01 * x - 0.02 * y),
    ]
    for salt, (name, grid, var, index, (x0, x1, y0, y1), f) in enumerate(linear):
        req = {"file": name, "grid": grid, "variable": var, "index": index,
               "lon": rng_axis(x0, x1, 17, 2 * salt), "lat": rng_axis(y0, y1, 13, 2 * salt + 1)}
        got = sample(out, req)
        worst, n_val, n_null = 0.0, 0, 0
        for v, (y, x) in zip(got, [(y, x) for y in req["lat"] for x in req["lon"]]):
            if v is None:
                n_null += 1
            elif v != "edge":
                n_val += 1
                worst = max(worst, abs(v - f(x, y)))
        expect(worst <= 1e-9, f"{name} {var} {index}: off the linear formula by {worst}")
        expect(n_val >= 200, f"{name} {var} {index}: only {n_val} values")
        # Only adcirc time 1 has missing data (the cells round the dry node).
        expect(n_null == 0 or (name == "adcirc.nc" and index["time"] == 1), f"{name} {var}: {n_null} nulls")
        if name == "adcirc.nc" and index["time"] == 1:
            expect(n_null > 0, "adcirc zeta time 1: the dry node's cells give no null")
        print(f"check linear {name:14} {var:10} {json.dumps(index):12} {n_val:4} values, {n_null:3} null, "
              f"max error {worst:.2e}")
    # Face values at the cells' centres (mean of the polygon's vertices, inside convex cells).
    faces = [("ugrid.nc", None, "depth", {}), ("ugrid_1based.nc", None, "depth", {}),
             ("ugrid.nc", None, "temp", {"time": 1}), ("icon_data.nc", None, "S", {"time": 1, "depth": 2}),
             ("icon_data_only.nc", "icon_grid.nc", "S", {"time": 0, "depth": 0}),
             ("mpas_data.nc", "mpas_grid.nc", "temperature", {"Time": 1, "nVertLevels": 1}),
             ("scrip_data.nc", "scrip_grid.nc", "T850", {}), ("scrip_data.nc", "scrip_grid_radians.nc", "T850", {}),
             ("fvcom.nc", None, "temp", {"time": 1, "siglay": 1})]
    for name, grid, var, index in faces:
        mesh, values, loc = open_request(out, {"file": name, "grid": grid, "variable": var, "index": index})
        px, py = [], []
        for lons, lats, _ in mesh.cells:
            xs, ys, _, _ = cell_polygon(lons, lats, np.zeros(len(lons)))
            plain = len(xs) == len(lons)  # no pole vertex, no ring round a pole
            px.append(float(np.mean(xs)) if plain else float("nan"))
            py.append(float(np.mean(ys)))
        ok = np.isfinite(px)
        got = sample_points(mesh, values, loc, np.array(px)[ok], np.array(py)[ok])
        want = [None if not np.isfinite(v) else float(v) for v in values[ok]]
        bad = sum(1 for g, w in zip(got, want) if g != w)
        expect(bad == 0, f"{name} {var}: {bad} centres give another value")
        print(f"check faces  {name:14} {var:11} {int(ok.sum()):4} centres, {bad} wrong, "
              f"{sum(w is None for w in want)} missing")
    # The global meshes cover every point once; the poles too.
    lon = np.array([-180 + 360 * hash01(k, 5, 1) for k in range(4000)] + [-179.0, 0.5, 33.3, 179.9] * 2)
    lat = np.array([-90 + 180 * hash01(k, 5, 2) for k in range(4000)] + [89.99] * 4 + [-89.99] * 4)
    for name, grid in (("icon_grid.nc", None), ("mpas_grid.nc", None)):
        with netCDF4.Dataset(os.path.join(out, name)) as ds:
            mesh = load_mesh(ds)
        polys = [cell_polygon(lo, la, np.zeros(len(lo))) for lo, la, _ in mesh.cells]
        edge, cell, _, count = locate(polys, lon, lat)
        once = np.all(count[~edge] == 1)
        expect(once, f"{name}: points covered {sorted(set(count[~edge].tolist()))} times")
        expect(np.all(cell[-8:] >= 0), f"{name}: a pole point is not covered")
        print(f"check cover  {name:14} {int((~edge).sum())} points each in one cell: {bool(once)}, "
              f"{int(edge.sum())} on edges")
    # The bad files fail to read.
    for name, grid, var, index in (("bad_index.nc", None, "depth", {}), ("bad_polygon.nc", None, "depth", {}),
                                   ("bad_units.nc", None, "S", {"time": 0, "depth": 0}),
                                   ("icon_data_mismatch.nc", "icon_grid.nc", "S", {"time": 0, "depth": 0})):
        try:
            open_request(out, {"file": name, "grid": grid, "variable": var, "index": index})
            failures.append(f"{name}: read without error")
        except Fail as exc:
            print(f"check bad    {name:22} refused: {exc}")
    for failure in failures:
        print("FAIL", failure, file=sys.stderr)
    return 1 if failures else 0


def main(argv):
    if len(argv) == 3 and argv[1] == "write":
        return write(argv[2])
    if len(argv) == 3 and argv[1] == "check":
        return check(argv[2])
    if len(argv) == 4 and argv[1] == "sample":
        with open(argv[3]) as f:
            request = json.load(f)
        try:
            values = sample(argv[2], request)
        except Fail as exc:
            print(f"error: {request.get('file')}: {exc}", file=sys.stderr)
            return 1
        json.dump({"values": values}, sys.stdout, separators=(",", ":"))
        sys.stdout.write("\n")
        return 0
    print(__doc__.split("\n\n")[1], file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
