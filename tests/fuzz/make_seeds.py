#!/usr/bin/env python3
"""Writes the generated seed inputs of tests/fuzz/corpus/<target>/ (committed; rerun after a
format changes). Small valid inputs of every decoder, so that fuzzing starts past the
header checks; real files from tests/data are copied or replayed beside them (CMakeLists.txt)."""
import json
import os
import shutil
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, '..', 'data')
SEQ = os.path.join(DATA, 'client_sim', 'S1_01_5kf', 'mav0')
W, H = 64, 48  # the fuzz session's camera (service_fixture.hpp)


def put(target, name, data):
    folder = os.path.join(HERE, 'corpus', target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), 'wb') as f:
        f.write(data.encode() if isinstance(data, str) else data)


def png16(width, height, depth_at, idat_chunks=1, bit_depth=16, colour=0):
    def chunk(kind, body):
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', zlib.crc32(kind + body))
    rows = b''
    for v in range(height):
        rows += b'\x00' + b''.join(struct.pack('>H', depth_at(u, v)) for u in range(width))
    z = zlib.compress(rows)
    step = max(1, len(z) // idat_chunks + 1)
    idats = b''.join(chunk(b'IDAT', z[i:i + step]) for i in range(0, len(z), step))
    ihdr = struct.pack('>IIBBBBB', width, height, bit_depth, colour, 0, 0, 0)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', ihdr) + idats + chunk(b'IEND', b'')


def blob(kind, raw):
    return b'MDB1' + struct.pack('<BHQI', kind, 1, len(raw), zlib.crc32(raw)) + zlib.compress(raw)


def lzf_literal(data):
    # LZF stream of literal runs only (control byte n < 32: n + 1 literal bytes follow).
    out = b''
    for i in range(0, len(data), 32):
        part = data[i:i + 32]
        out += bytes([len(part) - 1]) + part
    return out


POINTS = [(0.5, 1.0, 2.0), (-3.25, 4.0, 0.0), (10.0, -7.5, 1.5)]


def keyframe_meta():
    pose = {'t': [0, 0, 1.5], 'q': [1, 0, 0, 0]}
    put('fuzz_keyframe_meta', 'pose_only.json', json.dumps({'t_ns': 1000, 'T_map_cam': pose}))
    cov = [0.0] * 36
    for i in range(6):
        cov[i * 7] = 0.01
    put('fuzz_keyframe_meta', 'with_covariance.json', json.dumps({'t_ns': 2000, 'T_map_cam': pose, 'covariance': cov}))
    put('fuzz_keyframe_meta', 'null_covariance.json',
        json.dumps({'t_ns': 3, 'T_map_cam': {'t': [1e8, -2.5, 0.25], 'q': [0.70710678, 0, 0, 0.70710678]}, 'covariance': None}))


def depth_png():
    put('fuzz_depth_png', 'ramp.png', png16(W, H, lambda u, v: 1000 + 10 * u + v))
    put('fuzz_depth_png', 'sparse_three_idat.png', png16(W, H, lambda u, v: 4000 if (u * v) % 7 == 0 else 0, idat_chunks=3))
    put('fuzz_depth_png', 'empty_depth.png', png16(W, H, lambda u, v: 0))


def api_bodies():
    camera = {'width': 800, 'height': 450, 'fx': 400, 'fy': 400, 'cx': 400, 'cy': 225}
    put('fuzz_api_bodies', 'session.bin', b'\x00' + json.dumps({'vehicle_id': 'car-17', 'camera': camera}).encode())
    put('fuzz_api_bodies', 'session_scale.bin', b'\x00' + json.dumps({'vehicle_id': 'v', 'camera': camera, 'depth_scale': 5000}).encode())
    put('fuzz_api_bodies', 'job_refresh.bin', b'\x01' + json.dumps({'type': 'refresh', 'bbox': [-500, -500, 500, 500], 'min_confidence': 0.7}).encode())
    put('fuzz_api_bodies', 'job_reclassify.bin', b'\x01' + json.dumps({'type': 'reclassify', 'bbox': [-50, -50, 50, 50]}).encode())
    put('fuzz_api_bodies', 'bbox.bin', b'\x02-500,-500,500.5,500')
    put('fuzz_api_bodies', 'tile.bin', b'\x030_-1')


def blob_codec():
    raw = struct.pack('<Q', len(POINTS)) + b''.join(struct.pack('<fff', *p) for p in POINTS)
    put('fuzz_blob_codec', 'points.bin', b'\x00' + blob(1, raw))
    raw = struct.pack('<Q', 2)
    for key, p, sessions in (((0, 1, -2), POINTS[0], [1, 2]), ((5, 0, 0), POINTS[1], [3])):
        raw += struct.pack('<iiifffI', *key, *p, 7) + struct.pack('<I', len(sessions)) + b''.join(struct.pack('<q', s) for s in sessions)
    put('fuzz_blob_codec', 'aggregate.bin', b'\x01' + blob(2, raw))
    raw = struct.pack('<Q', 2)
    for p, kind, conf, obs, sup in ((POINTS[0], 0, 0.75, [1, 2], [1]), (POINTS[2], 1, 0.5, [4], [])):
        raw += struct.pack('<fffBf', *p, kind, conf)
        for ids in (obs, sup):
            raw += struct.pack('<I', len(ids)) + b''.join(struct.pack('<q', s) for s in ids)
    put('fuzz_blob_codec', 'changes.bin', b'\x02' + blob(3, raw))
    octree = open(os.path.join(DATA, '..', 'web', 'data', 'wall.bt'), 'rb').read()
    put('fuzz_blob_codec', 'observed.bin', b'\x03' + blob(4, octree))
    put('fuzz_blob_codec', 'observed_legacy_bare.bin', b'\x03' + octree)


def pcd():
    def header(fields, sizes, types, data):
        return ('# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS %s\nSIZE %s\nTYPE %s\nCOUNT %s\n'
                'WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA %s\n') % (
            fields, sizes, types, ' '.join('1' for _ in fields.split()), len(POINTS), len(POINTS), data)
    body = ''.join('%g %g %g\n' % p for p in POINTS)
    put('fuzz_pcd_reader', 'ascii.pcd', header('x y z', '4 4 4', 'F F F', 'ascii') + body)
    binary = b''.join(struct.pack('<fffB', *p, 9) + b'\x00\x00\x00' for p in POINTS)
    put('fuzz_pcd_reader', 'binary_xyz_intensity.pcd',
        header('x y z intensity _', '4 4 4 1 3', 'F F F U U', 'binary').encode() + binary)
    # binary_compressed: fields stored one after another (SoA), LZF-compressed.
    soa = b''.join(struct.pack('<%df' % len(POINTS), *[p[i] for p in POINTS]) for i in range(3))
    z = lzf_literal(soa)
    put('fuzz_pcd_reader', 'binary_compressed.pcd',
        header('x y z', '4 4 4', 'F F F', 'binary_compressed').encode() + struct.pack('<II', len(z), len(soa)) + z)


def ply():
    def header(fmt, extra=''):
        return ('ply\nformat %s 1.0\ncomment fuzz seed\nelement vertex %d\nproperty float x\nproperty float y\n'
                'property float z\n%selement face 0\nproperty list uchar int vertex_indices\nend_header\n') % (fmt, len(POINTS), extra)
    put('fuzz_ply_reader', 'ascii.ply', header('ascii', 'property uchar red\n') + ''.join('%g %g %g 200\n' % p for p in POINTS))
    put('fuzz_ply_reader', 'binary_le.ply', header('binary_little_endian').encode() + b''.join(struct.pack('<fff', *p) for p in POINTS))
    put('fuzz_ply_reader', 'binary_be_double.ply',
        header('binary_big_endian', 'property double nx\n').encode() + b''.join(struct.pack('>fffd', *p, 1.0) for p in POINTS))


def las():
    # Public header fields at the offsets of the ASPRS LAS 1.2 / 1.4 specifications (las_io.cpp).
    def file(minor, point_format, record_length):
        header_size = 375 if minor == 4 else 227
        h = bytearray(header_size)
        h[0:4] = b'LASF'
        h[24], h[25] = 1, minor
        struct.pack_into('<HII', h, 94, header_size, header_size, 0)
        struct.pack_into('<BHI', h, 104, point_format, record_length, len(POINTS))
        struct.pack_into('<3d3d', h, 131, 0.001, 0.001, 0.001, -4.0, -8.0, 0.0)
        if minor == 4:
            struct.pack_into('<Q', h, 247, len(POINTS))
        points = b''
        for p in POINTS:
            xyz = [round((p[0] + 4.0) / 0.001), round((p[1] + 8.0) / 0.001), round(p[2] / 0.001)]
            points += struct.pack('<3i', *xyz) + bytes(record_length - 12)
        return bytes(h) + points
    put('fuzz_las_reader', 'las12_format0.las', file(2, 0, 20))
    put('fuzz_las_reader', 'las14_format6.las', file(4, 6, 30))
    put('fuzz_las_reader', 'las12_format3_padded.las', file(2, 3, 40))


def octree_full():
    # OctoMap .ot (what the server stores per session): a chain from the root to one free leaf at
    # depth 16, each node its log-odds (float) and a byte of child bits.
    nodes = b''.join(struct.pack('<fB', 0.0, 1) for _ in range(16)) + struct.pack('<fB', -0.4, 0)
    header = b'# Octomap OcTree file\n# (feel free to add / change comments, but leave the first line as it is!)\n#\nid OcTree\nsize 17\nres 0.8\ndata\n'
    put('fuzz_octree_bt', 'chain.ot', header + nodes)


def copied():
    shutil.copy(os.path.join(DATA, '..', 'web', 'data', 'wall.bt'), os.path.join(HERE, 'corpus', 'fuzz_octree_bt', 'wall.bt'))
    for name in ('cam0', 'imu0', 'depth0'):
        put('fuzz_sensor_yaml', name + '_sensor.yaml', open(os.path.join(SEQ, name, 'sensor.yaml'), 'rb').read())
    for name, path in (('cam0_data.csv', 'cam0/data.csv'), ('imu0_data.csv', 'imu0/data.csv'),
                       ('groundtruth.csv', 'state_groundtruth_estimate0/data.csv')):
        lines = open(os.path.join(SEQ, path), 'rb').read().splitlines(keepends=True)
        put('fuzz_euroc_csv', name, b''.join(lines[:8]))  # a few rows: fuzzing wants short inputs
    lines = open(os.path.join(DATA, 'tum_fr2_desk', 'fr2_desk_ORB.txt'), 'rb').read().splitlines(keepends=True)
    put('fuzz_euroc_csv', 'tum.txt', b''.join(lines[:8]))
    put('fuzz_server_config', 'server.example.yaml', open(os.path.join(HERE, '..', '..', 'config', 'server.example.yaml'), 'rb').read())


if __name__ == '__main__':
    os.makedirs(os.path.join(HERE, 'corpus', 'fuzz_octree_bt'), exist_ok=True)
    for make in (keyframe_meta, depth_png, api_bodies, blob_codec, pcd, ply, las, octree_full, copied):
        make()
