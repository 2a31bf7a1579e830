"""A reduced SVBRDF as a glTF 2.0 binary file (``material.glb``): a plane carrying it as a
metallic-roughness material, for the renderers and tools artists use.

The plane is a rectangle of the maps' aspect, its longer side 1 (the square [-0.5, 0.5]^2 for
square maps), centred in glTF's x-y plane, facing +z (glTF is y-up, so the
sample stands like a wall facing the default camera); texture u grows with +x and v with -y,
so the image's row 0 is at the top, as in every map of this project.

Mapping of the reduced model (docs/gltf.md gives the reasoning and the known differences):
- **Scale.** The estimate's albedos are relative (mean 0.5) and may exceed 1; glTF's are
  reflectances in [0, 1]. Diffuse and specular albedo are divided by one common factor,
  max(1, largest diffuse albedo, largest specular albedo), which keeps their ratio (what a
  photo shows) and clips nothing.
- **baseColorTexture**: the diffuse albedo, sRGB-encoded 8-bit PNG. metallicFactor 0: the
  reduced model is one diffuse and one specular lobe, which glTF's dielectric BRDF also is.
- **KHR_materials_specular**: specularColorFactor = rho_s / 0.04 (linear RGB), specularFactor
  1, so the dielectric's normal-incidence reflectance F0 = 0.04 x specularColor = rho_s: the
  Ward lobe's albedo is about its F0 for a microfacet lobe. Values above 1 are allowed by the
  extension.
- **roughnessFactor** = sqrt(Ward alpha): glTF's GGX takes alpha = roughness^2, and a Ward
  (Beckmann-like) alpha and a GGX alpha give lobes of about the same width.
- **normalTexture**: the tangent-space normals, (n + 1) / 2 in 8-bit linear PNG, +x right,
  +y up (glTF's and this project's convention); tangents are supplied (+x, w = +1).
"""

import io
from pathlib import Path

import numpy as np
import pygltflib
from PIL import Image

from render.common.atomic_files import atomic_path
from render.common.color import normal_to_png_bytes, to_png_bytes
from render.materials.reduced_svbrdf import ReducedSVBRDF

DIELECTRIC_F0 = 0.04
"""glTF's dielectric reflectance at normal incidence with the default IOR 1.5."""

_CORNERS = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]],
                    np.float32)
_TEXCOORDS = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
_NORMALS = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
_TANGENTS = np.tile(np.array([1, 0, 0, 1], np.float32), (4, 1))
_INDICES = np.array([0, 1, 2, 0, 2, 3], np.uint16)


def gltf_parameters(svbrdf: ReducedSVBRDF) -> dict:
    """The glTF values of the module docstring's mapping: dict of base_color (H, W, 3) linear
    in [0, 1], specular_color_factor (3,), roughness_factor, and scale, the common factor the
    albedos were divided by."""
    scale = max(1.0, float(svbrdf.albedo.max()), float(np.max(svbrdf.specular)))
    return {"scale": scale, "base_color": np.clip(svbrdf.albedo / scale, 0.0, 1.0),
            "specular_color_factor": (np.asarray(svbrdf.specular, np.float64) / scale
                                      / DIELECTRIC_F0),
            "roughness_factor": float(np.sqrt(svbrdf.roughness))}


def _png(pixels_uint8):
    buffer = io.BytesIO()
    Image.fromarray(pixels_uint8).save(buffer, format="PNG")
    return buffer.getvalue()


def write_gltf_file(path: str | Path, svbrdf: ReducedSVBRDF) -> str | Path:
    """Write ``svbrdf`` (a ReducedSVBRDF) as a glTF 2.0 binary file at ``path`` (atomically);
    returns the path."""
    values = gltf_parameters(svbrdf)
    height, width = svbrdf.albedo.shape[:2]
    positions = _CORNERS * np.array([width, height, 1], np.float32) / max(width, height)
    blobs = [positions.tobytes(), _NORMALS.tobytes(), _TANGENTS.tobytes(), _TEXCOORDS.tobytes(),
             _INDICES.tobytes(), _png(to_png_bytes(values["base_color"])),
             _png(normal_to_png_bytes(svbrdf.normal))]
    views, offset = [], 0
    for index, blob in enumerate(blobs):
        target = (pygltflib.ARRAY_BUFFER if index < 4 else
                  pygltflib.ELEMENT_ARRAY_BUFFER if index == 4 else None)
        views.append(pygltflib.BufferView(buffer=0, byteOffset=offset, byteLength=len(blob),
                                          target=target))
        offset += len(blob) + (-len(blob)) % 4  # each view starts 4-byte aligned
    binary = b"".join(blob + b"\0" * ((-len(blob)) % 4) for blob in blobs)
    accessors = [
        pygltflib.Accessor(bufferView=0, componentType=pygltflib.FLOAT, count=4, type="VEC3",
                           min=positions.min(0).tolist(), max=positions.max(0).tolist()),
        pygltflib.Accessor(bufferView=1, componentType=pygltflib.FLOAT, count=4, type="VEC3"),
        pygltflib.Accessor(bufferView=2, componentType=pygltflib.FLOAT, count=4, type="VEC4"),
        pygltflib.Accessor(bufferView=3, componentType=pygltflib.FLOAT, count=4, type="VEC2"),
        pygltflib.Accessor(bufferView=4, componentType=pygltflib.UNSIGNED_SHORT, count=6,
                           type="SCALAR"),
    ]
    material = pygltflib.Material(
        name=svbrdf.name or "estimate",
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorTexture=pygltflib.TextureInfo(index=0), metallicFactor=0.0,
            roughnessFactor=values["roughness_factor"]),
        normalTexture=pygltflib.NormalMaterialTexture(index=1),
        extensions={"KHR_materials_specular": {
            "specularFactor": 1.0,
            "specularColorFactor": [float(v) for v in values["specular_color_factor"]]}})
    gltf = pygltflib.GLTF2(
        asset=pygltflib.Asset(version="2.0", generator="sa-svbrdf"),
        extensionsUsed=["KHR_materials_specular"],
        scene=0, scenes=[pygltflib.Scene(nodes=[0])],
        nodes=[pygltflib.Node(mesh=0, name="sample")],
        meshes=[pygltflib.Mesh(name="sample", primitives=[pygltflib.Primitive(
            attributes=pygltflib.Attributes(POSITION=0, NORMAL=1, TANGENT=2, TEXCOORD_0=3),
            indices=4, material=0)])],
        materials=[material],
        samplers=[pygltflib.Sampler(magFilter=pygltflib.LINEAR,
                                    minFilter=pygltflib.LINEAR_MIPMAP_LINEAR)],
        images=[pygltflib.Image(bufferView=5, mimeType="image/png", name="base_color"),
                pygltflib.Image(bufferView=6, mimeType="image/png", name="normal")],
        textures=[pygltflib.Texture(sampler=0, source=0), pygltflib.Texture(sampler=0, source=1)],
        accessors=accessors, bufferViews=views,
        buffers=[pygltflib.Buffer(byteLength=len(binary))])
    gltf.set_binary_blob(binary)
    with atomic_path(path) as tmp:
        tmp.write_bytes(b"".join(gltf.save_to_bytes()))
    return path
