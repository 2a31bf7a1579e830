"""Renders sa-estimate's ``material.glb`` in Blender (Cycles) as render/mitsuba_reference
renders the estimate: orthographic view straight down on the sample, which fills the frame,
under the same white-balanced probe in the same orientation. Runs inside Blender:

    blender -b --factory-startup --python scripts/blender_render_gltf.py -- \\
        MATERIAL.glb PROBE.exr OUT.exr WIDTH HEIGHT [SAMPLES]

Frames. The glTF plane faces glTF +z, which Blender's importer turns into Blender -y (glTF is
y-up, Blender z-up), the image's top toward Blender +z. The project's world (docs/
conventions.md: +z up out of the sample, image right +x, image up +y) is therefore
world = (x_b, z_b, -y_b). The probe's pixel (row, column) lies at polar
angle pi row / H from world +z and azimuth -2 pi column / W from world +x; Blender's
environment texture puts azimuth 0 at the image's middle, so the lookup direction is the
world direction turned 180 degrees about +z: (-x_b, -z_b, -y_b).
Output: linear HDR radiance, OpenEXR, the image's row 0 at the sample's top.
"""

import sys

import bpy
import numpy


def main(glb, probe, out, width, height, samples):
    # Debian's Blender 3.4 glTF importer still uses numpy.bool, which Debian's numpy 1.24 no
    # longer has; the alias was the builtin bool.
    if not hasattr(numpy, "bool"):
        numpy.bool = bool
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=glb)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 1  # direct light only, as Mitsuba's "direct" integrator
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.filter_size = 0.01  # a box of one pixel, as the Mitsuba film
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"

    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 1.0  # the plane's longer side
    camera.location = (0.0, -10.0, 0.0)
    camera.rotation_euler = (1.5707963267948966, 0.0, 0.0)  # looking along +y, up +z
    scene.collection.objects.link(camera)
    scene.camera = camera

    world = bpy.data.worlds.new("probe")
    scene.world = world
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    coordinates = nodes.new("ShaderNodeTexCoord")
    split = nodes.new("ShaderNodeSeparateXYZ")
    combine = nodes.new("ShaderNodeCombineXYZ")
    links.new(coordinates.outputs["Generated"], split.inputs[0])
    for target, source in (("X", "X"), ("Y", "Z"), ("Z", "Y")):  # (-x_b, -z_b, -y_b)
        negate = nodes.new("ShaderNodeMath")
        negate.operation = "MULTIPLY"
        negate.inputs[1].default_value = -1.0
        links.new(split.outputs[source], negate.inputs[0])
        links.new(negate.outputs[0], combine.inputs[target])
    environment = nodes.new("ShaderNodeTexEnvironment")
    environment.image = bpy.data.images.load(probe)
    environment.image.colorspace_settings.name = "Non-Color"  # linear radiance as stored
    environment.interpolation = "Linear"
    links.new(combine.outputs[0], environment.inputs["Vector"])
    background = nodes.new("ShaderNodeBackground")
    links.new(environment.outputs["Color"], background.inputs["Color"])
    output = nodes.new("ShaderNodeOutputWorld")
    links.new(background.outputs[0], output.inputs[0])

    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    arguments = sys.argv[sys.argv.index("--") + 1:]
    main(arguments[0], arguments[1], arguments[2], int(arguments[3]), int(arguments[4]),
         int(arguments[5]) if len(arguments) > 5 else 256)
