"""Rewrites frame 2 of the SPlisHSPlasH VTK fixture (../vtk/ParticleData_Fluid_2.vtk) as
VTK XML files the way ParaView's writers (VTK's vtkXMLWriter) and meshio save them: every
data mode, encoding, compressor, header width and byte order activeskin reads.

    pip install vtk meshio    # vtk 9.7.2, meshio 5.3.5 made the committed files
    python3 data/sph/vtu/make_fixtures.py
"""
import os

import meshio
import vtk

here = os.path.dirname(os.path.abspath(__file__))
source = os.path.join(here, "..", "vtk", "ParticleData_Fluid_2.vtk")

reader = vtk.vtkUnstructuredGridReader()
reader.SetFileName(source)
reader.ReadAllScalarsOn()
reader.ReadAllVectorsOn()
reader.ReadAllFieldsOn()
reader.Update()
grid = reader.GetOutput()


def configure(w, mode, compressor, header, big_endian, encode=False, block=None):
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended}[mode]()
    w.SetEncodeAppendedData(encode)
    {"none": w.SetCompressorTypeToNone, "zlib": w.SetCompressorTypeToZLib,
     "lz4": w.SetCompressorTypeToLZ4, "lzma": w.SetCompressorTypeToLZMA}[compressor]()
    {32: w.SetHeaderTypeToUInt32, 64: w.SetHeaderTypeToUInt64}[header]()
    (w.SetByteOrderToBigEndian if big_endian else w.SetByteOrderToLittleEndian)()
    if block:
        w.SetBlockSize(block)


def write_vtu(name, **options):
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(os.path.join(here, name))
    w.SetInputData(grid)
    configure(w, **options)
    assert w.Write() == 1, name


write_vtu("ascii.vtu", mode="ascii", compressor="none", header=64, big_endian=False)
write_vtu("binary.vtu", mode="binary", compressor="none", header=32, big_endian=False)
# Blocks of 1 KiB: every array spans several compressed blocks.
write_vtu("binary_zlib.vtu", mode="binary", compressor="zlib", header=64, big_endian=False,
          block=1024)
write_vtu("appended_raw.vtu", mode="appended", compressor="none", header=32, big_endian=True)
write_vtu("appended_raw_zlib.vtu", mode="appended", compressor="zlib", header=64,
          big_endian=False)
write_vtu("appended_base64_lz4.vtu", mode="appended", compressor="lz4", header=32,
          big_endian=False, encode=True, block=2048)
write_vtu("appended_lzma.vtu", mode="appended", compressor="lzma", header=64,
          big_endian=True)

# PolyData (.vtp): the same points as vertices.
poly = vtk.vtkPolyData()
poly.SetPoints(grid.GetPoints())
poly.GetPointData().ShallowCopy(grid.GetPointData())
vertices = vtk.vtkCellArray()
for i in range(grid.GetNumberOfPoints()):
    vertices.InsertNextCell(1)
    vertices.InsertCellPoint(i)
poly.SetVerts(vertices)
w = vtk.vtkXMLPolyDataWriter()
w.SetFileName(os.path.join(here, "polydata.vtp"))
w.SetInputData(poly)
configure(w, mode="appended", compressor="zlib", header=64, big_endian=False)
assert w.Write() == 1

# A parallel file: two pieces, each its own .vtu (the first 200 particles, the rest),
# listed by pieces.pvtu as vtkXMLPUnstructuredGridWriter lists them.
def piece(first, last):
    ids = vtk.vtkIdTypeArray()
    for i in range(first, last):
        ids.InsertNextValue(i)
    node = vtk.vtkSelectionNode()
    node.SetFieldType(vtk.vtkSelectionNode.POINT)
    node.SetContentType(vtk.vtkSelectionNode.INDICES)
    node.SetSelectionList(ids)
    selection = vtk.vtkSelection()
    selection.AddNode(node)
    extract = vtk.vtkExtractSelection()
    extract.SetInputData(0, grid)
    extract.SetInputData(1, selection)
    extract.Update()
    part = extract.GetOutput()
    part.GetPointData().RemoveArray("vtkOriginalPointIds")
    part.GetCellData().RemoveArray("vtkOriginalCellIds")
    return part


for k, (first, last) in enumerate([(0, 200), (200, grid.GetNumberOfPoints())]):
    write_vtu_data = vtk.vtkXMLUnstructuredGridWriter()
    write_vtu_data.SetFileName(os.path.join(here, f"pieces_{k}.vtu"))
    write_vtu_data.SetInputData(piece(first, last))
    configure(write_vtu_data, mode="binary", compressor="zlib", header=64, big_endian=False)
    assert write_vtu_data.Write() == 1
with open(os.path.join(here, "pieces.pvtu"), "w") as f:
    f.write("""<?xml version="1.0"?>
<VTKFile type="PUnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
  <PUnstructuredGrid GhostLevel="0">
    <PPointData Scalars="id">
      <PDataArray type="UInt32" Name="id"/>
      <PDataArray type="Float32" Name="velocity" NumberOfComponents="3"/>
    </PPointData>
    <PPoints>
      <PDataArray type="Float32" Name="Points" NumberOfComponents="3"/>
    </PPoints>
    <Piece Source="pieces_0.vtu"/>
    <Piece Source="pieces_1.vtu"/>
  </PUnstructuredGrid>
</VTKFile>
""")

# meshio's writer (zlib, base64 inline, its own header layout).
mesh = meshio.read(source)
meshio.write(os.path.join(here, "meshio.vtu"), mesh, binary=True)
