// The ellipse inscribed in the viewport, in a constant colour; PB_PER_SAMPLE interpolates the
// barycentrics at each sample, so the test runs per sample as aaps_splat.glsl's does.
#ifdef PB_PER_SAMPLE
layout(location = 0) sample in vec2 bary;
#else
layout(location = 0) in vec2 bary;
#endif
layout(push_constant) uniform Push { vec4 colour; }
push;
layout(location = 0) out vec4 colour;
void main() {
  if (dot(bary, bary) > 1.0) discard;
  colour = push.colour;
}
