// Drawing a mesh with WebGL2: every triangle in one draw call, coloured in the fragment shader
// through the colour map as a texture, so 200,000 triangles pan and zoom at screen rate.
// Coordinates are uploaded relative to the mesh's centre: float32 keeps its precision there.

import { VIRIDIS } from "./colormap.js";

const TRI_VS = `#version 300 es
in vec2 a_pos;
in float a_value;
uniform vec2 u_offset;
uniform vec2 u_scale;
out float v_value;
void main() {
  v_value = a_value;
  gl_Position = vec4((a_pos + u_offset) * u_scale, 0.0, 1.0);
}`;

const TRI_FS = `#version 300 es
precision highp float;
in float v_value;
uniform sampler2D u_map;
uniform vec2 u_range;   // the values at the two ends of the colour map
out vec4 color;
void main() {
  float t = clamp((v_value - u_range.x) / (u_range.y - u_range.x), 0.0, 1.0);
  color = texture(u_map, vec2((t * 255.0 + 0.5) / 256.0, 0.5));
}`;

const LINE_VS = `#version 300 es
in vec2 a_pos;
uniform vec2 u_offset;
uniform vec2 u_scale;
void main() {
  gl_Position = vec4((a_pos + u_offset) * u_scale, 0.0, 1.0);
}`;

const LINE_FS = `#version 300 es
precision mediump float;
uniform vec4 u_color;
out vec4 color;
void main() { color = u_color; }`;

function compile(gl, vs, fs) {
  const program = gl.createProgram();
  for (const [type, source] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
    gl.attachShader(program, shader);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
  const uniforms = {};
  for (let i = 0; i < gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS); i++) {
    const name = gl.getActiveUniform(program, i).name;
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return { program, uniforms };
}

/** Whether WebGL runs on the CPU (SwiftShader, llvmpipe): there, multisampling doubles the
 * cost of a frame, so it is left off. */
function softwareGL() {
  const probe = document.createElement("canvas").getContext("webgl2");
  if (!probe) return false;
  const info = probe.getExtension("WEBGL_debug_renderer_info");
  const name = String(probe.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : probe.RENDERER));
  const lose = probe.getExtension("WEBGL_lose_context");
  if (lose) lose.loseContext();
  return /swiftshader|llvmpipe|softpipe|software/i.test(name);
}

export class GLRenderer {
  /** Throws when the browser has no WebGL2 (the caller falls back to canvas 2D). */
  constructor(canvas) {
    this.software = softwareGL();
    const gl = canvas.getContext("webgl2", { antialias: !this.software, alpha: false });
    if (!gl) throw new Error("WebGL2 is not available");
    this.name = this.software ? "webgl2 (software)" : "webgl2";
    this.gl = gl;
    this.tri = compile(gl, TRI_VS, TRI_FS);
    this.line = compile(gl, LINE_VS, LINE_FS);
    this.buffers = {};
    this.mesh = null;
    this.range = [0, 1];
    this._colormap();
  }

  _colormap() {
    const gl = this.gl;
    const rgba = new Uint8Array(256 * 4);
    for (let i = 0; i < 256; i++) {
      rgba.set([VIRIDIS[3 * i], VIRIDIS[3 * i + 1], VIRIDIS[3 * i + 2], 255], 4 * i);
    }
    this.texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, 256, 1, 0, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  }

  _buffer(name, target, data) {
    const gl = this.gl;
    if (this.buffers[name]) gl.deleteBuffer(this.buffers[name]);
    const buffer = gl.createBuffer();
    gl.bindBuffer(target, buffer);
    gl.bufferData(target, data, gl.STATIC_DRAW);
    this.buffers[name] = buffer;
    return buffer;
  }

  /** Upload a mesh's geometry (positions relative to its centre). */
  setMesh(mesh) {
    const gl = this.gl;
    this.mesh = mesh;
    const [x0, y0, x1, y1] = mesh.box;
    this.origin = [(x0 + x1) / 2, (y0 + y1) / 2];
    const { xy, tri } = mesh;
    const nodes = new Float32Array(xy.length);
    for (let i = 0; i < xy.length; i += 2) {
      nodes[i] = xy[i] - this.origin[0];
      nodes[i + 1] = xy[i + 1] - this.origin[1];
    }
    const corners = new Float32Array(2 * tri.length);
    for (let c = 0; c < tri.length; c++) {
      corners[2 * c] = nodes[2 * tri[c]];
      corners[2 * c + 1] = nodes[2 * tri[c] + 1];
    }
    const triLoc = gl.getAttribLocation(this.tri.program, "a_pos");
    const lineLoc = gl.getAttribLocation(this.line.program, "a_pos");

    for (const vao of [this.triVao, this.lineVao]) if (vao) gl.deleteVertexArray(vao);
    this.triVao = gl.createVertexArray();
    gl.bindVertexArray(this.triVao);
    this._buffer("corners", gl.ARRAY_BUFFER, corners);
    gl.enableVertexAttribArray(triLoc);
    gl.vertexAttribPointer(triLoc, 2, gl.FLOAT, false, 0, 0);
    this._buffer("values", gl.ARRAY_BUFFER, new Float32Array(tri.length));
    const valueLoc = gl.getAttribLocation(this.tri.program, "a_value");
    gl.enableVertexAttribArray(valueLoc);
    gl.vertexAttribPointer(valueLoc, 1, gl.FLOAT, false, 0, 0);

    this.lineVao = gl.createVertexArray();
    gl.bindVertexArray(this.lineVao);
    this._buffer("nodes", gl.ARRAY_BUFFER, nodes);
    gl.enableVertexAttribArray(lineLoc);
    gl.vertexAttribPointer(lineLoc, 2, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    this._buffer("edges", gl.ELEMENT_ARRAY_BUFFER, mesh.edges);
    this._buffer("outline", gl.ELEMENT_ARRAY_BUFFER, mesh.outline);
  }

  /** Colour by per-triangle or per-node values over [lo, hi] (lo > hi reverses the map). */
  setColors(values, perNode, lo, hi) {
    const gl = this.gl;
    const tri = this.mesh.tri;
    const corner = new Float32Array(tri.length);
    if (perNode) for (let c = 0; c < tri.length; c++) corner[c] = values[tri[c]];
    else for (let c = 0; c < tri.length; c++) corner[c] = values[(c / 3) | 0];
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.values);
    gl.bufferData(gl.ARRAY_BUFFER, corner, gl.STATIC_DRAW);
    this.range = [lo, hi];
  }

  /** Draw at a view: {width, height (device pixels), scale (device pixels per unit), cx, cy}. */
  draw(view, options) {
    const gl = this.gl;
    gl.viewport(0, 0, view.width, view.height);
    gl.clearColor(0.984, 0.988, 0.992, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    if (!this.mesh) return;
    const offset = [this.origin[0] - view.cx, this.origin[1] - view.cy];
    const scale = [(2 * view.scale) / view.width, (2 * view.scale) / view.height];

    gl.useProgram(this.tri.program);
    gl.uniform2fv(this.tri.uniforms.u_offset, offset);
    gl.uniform2fv(this.tri.uniforms.u_scale, scale);
    gl.uniform2fv(this.tri.uniforms.u_range, this.range);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.uniform1i(this.tri.uniforms.u_map, 0);
    gl.bindVertexArray(this.triVao);
    gl.drawArrays(gl.TRIANGLES, 0, this.mesh.tri.length);

    gl.useProgram(this.line.program);
    gl.uniform2fv(this.line.uniforms.u_offset, offset);
    gl.uniform2fv(this.line.uniforms.u_scale, scale);
    gl.bindVertexArray(this.lineVao);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
    if (options.edgeAlpha > 0) {
      gl.uniform4fv(this.line.uniforms.u_color, [1, 1, 1, options.edgeAlpha]);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers.edges);
      gl.drawElements(gl.LINES, this.mesh.edges.length, gl.UNSIGNED_INT, 0);
    }
    gl.uniform4fv(this.line.uniforms.u_color, [0.12, 0.16, 0.2, 0.9]);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers.outline);
    gl.drawElements(gl.LINES, this.mesh.outline.length, gl.UNSIGNED_INT, 0);
    gl.disable(gl.BLEND);
    gl.bindVertexArray(null);
  }

  /** Wait until the GPU has drawn (for timing): reading a pixel back cannot happen sooner
   * (gl.finish() returns at once in some browsers). */
  finish() {
    this.gl.readPixels(0, 0, 1, 1, this.gl.RGBA, this.gl.UNSIGNED_BYTE, new Uint8Array(4));
  }
}
