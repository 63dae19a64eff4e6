"""Hostile inputs, each small, each claiming far less than it holds (issue 52):

    python3 data/hostile/make_hostile.py

lzma_bomb.vtu: 400 points whose one LZMA block says 4 800 bytes and inflates to 1.5 GB of
zeros (a 300 KB file): a reader must stop at the stated size, never inflate then check.
"""
import base64
import lzma
import os
import struct

here = os.path.dirname(os.path.abspath(__file__))

n = 400
stated = n * 3 * 4
compressor = lzma.LZMACompressor(format=lzma.FORMAT_XZ, check=lzma.CHECK_CRC64)
zeros = bytes(16 << 20)
packed = b"".join(compressor.compress(zeros) for _ in range(96)) + compressor.flush()
header = struct.pack("<4I", 1, stated, stated, len(packed))
data = base64.b64encode(header).decode() + base64.b64encode(packed).decode()
xml = f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt32" compressor="vtkLZMADataCompressor">
  <UnstructuredGrid>
    <Piece NumberOfPoints="{n}" NumberOfCells="0">
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="binary">
          {data}
        </DataArray>
      </Points>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"""
with open(os.path.join(here, "lzma_bomb.vtu"), "w") as f:
    f.write(xml)
