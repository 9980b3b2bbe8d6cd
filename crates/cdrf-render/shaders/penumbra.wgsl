// The penumbra: a shadowed light's visibility V at a point, and the transmission T(d, μ)
// through its occluders and thin parts, from the light's shadow map compared with the point's
// local shape over a spiral of taps (docs/shading.md, "Non-local terms").

// Principal curvatures may differ from the mean curvature the mesh carries (saddles, cylinders):
// an occluder counts only if it is nearer the light than this much extra curvature explains.
const CURVATURE_ALLOWANCE_PER_MM: f32 = 0.05;
const GOLDEN_ANGLE: f32 = 2.39996322972865;

// A tap of the spiral moved onto the local shape: where it lies and which way it faces.
struct Tap {
    surface: vec3<f32>,
    facing: vec3<f32>,
    // Distance from the point on the tangent plane, mm.
    radius_mm: f32,
}

// Tap k of a Vogel spiral over the disc of radius `disc_mm` on the tangent plane (tap 0 at the
// centre), moved onto the local shape.
fn spiral_tap(shape: LocalShape, k: u32, disc_mm: f32) -> Tap {
    var tap: Tap;
    tap.radius_mm = disc_mm * sqrt(f32(k) / f32(PENUMBRA_TAPS));
    let angle = f32(k) * GOLDEN_ANGLE;
    tap.surface = shape.point
        + tap.radius_mm * (cos(angle) * shape.tangent + sin(angle) * shape.bitangent);
    tap.facing = shape.normal;
    if shape.curved {
        tap.facing = normalize(tap.surface - shape.centre);
        tap.surface = shape.centre + shape.radius_mm * tap.facing;
    }
    return tap;
}

// The depth (mm) of the first surface the local shape puts in the tap's column: the tap itself
// where it faces the light, else the near end of the shape's chord through it; −∞ (−1e30) for
// a plane facing away (no surface in front of it). `along`: the cosine between the tap's
// facing and the light's ray there.
fn expected_first_surface(shape: LocalShape, tap: Tap, depth_mm: f32, along: f32) -> f32 {
    if along > 0.0 {
        if shape.curved {
            return depth_mm - 2.0 * shape.radius_mm * along;
        }
        return -1e30;
    }
    return depth_mm;
}

// Allowed mismatch between the map and the local shape (mm): the bias, plus (half a texel across
// the light, and the shape's sag if its principal curvatures differ from the mean by up to
// CURVATURE_ALLOWANCE) turned into depth by the surface's slope — at most σ + 4 texels, so
// grazing light still sees occluders farther away than the penumbra is wide.
fn column_tolerance(
    tap: Tap,
    ray: vec3<f32>,
    curvature_per_mm: f32,
    texel_mm: f32,
    sigma_max_mm: f32,
) -> f32 {
    let sag = 0.5 * tap.radius_mm * tap.radius_mm
        * (abs(curvature_per_mm) + CURVATURE_ALLOWANCE_PER_MM);
    let along = dot(tap.facing, ray);
    let across = 0.5 * texel_mm * length(tap.facing - along * ray) + sag;
    return shadows.depth_bias_mm
        + min(across / max(abs(along), 1e-3), sigma_max_mm + 4.0 * texel_mm);
}

// Compare the shadow map of light `index` around the point with the osculating sphere (or
// tangent plane) of the point (docs/shading.md, "Non-local terms"). Directional lights' maps are orthographic; point and
// spot lights' perspective, their columns the rays from the light and depths the distances
// from it.
fn non_local_terms(
    index: u32,
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
) -> NonLocalTerms {
    let depth_range_mm = shadows.lights[index].depth_range * shadows.mm_per_world_unit;
    let shape = local_shape(
        light_frame_point(index, world_position),
        light_frame_vector(index, normal),
        curvature_per_mm,
    );
    let p = shape.point;
    let n = shape.normal;
    let p_depth = light_depth(index, p);
    let n_along = dot(n, light_ray(index, p));
    let texel_mm = texel_width_mm(index, p);
    let sigma = material.scattering_length_mm;
    let sigma_max = max(sigma.x, max(sigma.y, sigma.z));
    // T(d, μ), unless the subsurface gather brings that light instead (vertex_non_local).
    let gathers = gathers_subsurface();
    let transmits = TRANSMISSION && !gathers;
    // The penumbra's width: the light the CDRF spreads under a shadow's edge reaches about σ;
    // with the subsurface gather the table keeps only its near field, which reaches about the
    // cut ℓ_c (the gather brings the rest from the lit surface that is there), each channel
    // as far as its own near field does (the taps' weights).
    var penumbra_mm = sigma_max;
    if gathers {
        penumbra_mm = material.subsurface_cut_mm;
    }
    var taps = 1u;
    if penumbra_mm > texel_mm {
        taps = PENUMBRA_TAPS;
    }
    // The same spiral at every point (no per-point rotation) and every tap read: the result
    // is a continuous function of the point up to the taps' texel steps, so interpolating it
    // between vertices cannot blotch; PENUMBRA_TAPS is large enough that its steps do not band.
    var unoccluded = vec3<f32>(0.0);
    var weights = vec3<f32>(0.0);
    // Occluded columns (counted − lit of them): their weight, and their summed distance through
    // the occluder.
    var through_weight = vec3<f32>(0.0);
    var through_mm = 0.0;
    // The first occluded column (its entry cosine is read after the loop), and whether the
    // centre column shows a part thinner than the local shape (read after the loop too).
    // Nothing that reads the map beyond a tap's own texel stays inside the loop: software
    // rasterisers run a branch's code for every tap even where no invocation takes it.
    var first_occluded = Column(vec2<i32>(-1), 0u, 0.0);
    var centre_column = Column(vec2<i32>(-1), 0u, 0.0);
    var centre_lit = false;
    var centre_expected_mm = 0.0;
    var centre_tolerance_mm = 0.0;
    var counted = 0u;
    var lit = 0u;
    // Every tap is read: where a few probes decide whether to read the rest, neighbouring
    // vertices jump between all-or-nothing and the full average (hard, jagged shadow edges).
    for (var k = 0u; k < taps; k++) {
        let tap = spiral_tap(shape, k, PENUMBRA_DISC_PER_WIDTH * penumbra_mm);
        let ray = light_ray(index, tap.surface);
        let tap_depth = light_depth(index, tap.surface);
        let expected = expected_first_surface(shape, tap, tap_depth, dot(tap.facing, ray));
        let column = shadow_column(index, tap.surface);
        let occluder = column.first_surface_mm;
        let tolerance = column_tolerance(tap, ray, curvature_per_mm, texel_mm, sigma_max);
        // No surface where the local shape puts one (the tangent plane reaching over a hole or
        // past an edge): this column says nothing about the light near the point.
        if k > 0u && expected > -1e29 && occluder > expected + tolerance {
            continue;
        }
        // The tap's weight per channel, precomputed per material: a Gaussian of σ per channel;
        // with the gather, the share of the table's near field that lands at the tap's ring
        // (a channel that diffuses a short way sees only the lit surface close to the point).
        var weight = vec3<f32>(1.0);
        if taps > 1u {
            if gathers {
                // A tap downstream of the point counts less, lit or not: the light entering
                // there moves on along the light's travel, away from the point, before it
                // diffuses (cdrf-core's NEAR_FIELD_UPSTREAM_LOSS). The centre tap, the point
                // itself, keeps its weight.
                weight = material.near_field_taps[k].weight;
                if k > 0u {
                    // The tap lies its radius from the point (to within the shape's sag).
                    let c = dot(p - tap.surface, ray) / tap.radius_mm;
                    weight *= upstream_share(c, NEAR_FIELD_UPSTREAM_LOSS);
                }
            } else {
                weight = material.penumbra_taps[k].weight;
            }
        }
        weights += weight;
        counted += 1u;
        if occluder < expected - tolerance {
            through_weight += weight;
            through_mm += tap_depth - occluder;
            if counted == lit + 1u {
                first_occluded = column;
            }
        } else {
            unoccluded += weight;
            lit += 1u;
            if k == 0u {
                centre_lit = true;
                centre_column = column;
                centre_expected_mm = expected;
                centre_tolerance_mm = tolerance;
            }
        }
    }
    var terms = no_terms();
    terms.visibility = unoccluded / weights;
    if centre_lit && n_along > 0.0 {
        // The body's own thickness along the light here (T(d, μ) clamps it at 0 too).
        terms.thickness_mm = max(p_depth - centre_column.first_surface_mm, 0.0);
        if transmits {
            terms.transmission = smoothstep(0.0, THIN_PART_FADE_END, n_along)
                * thin_part_transmission(
                    centre_column.layer,
                    centre_column.texel,
                    terms.thickness_mm,
                    p_depth - centre_expected_mm - centre_tolerance_mm,
                    texel_mm,
                    depth_range_mm,
                );
        }
    }
    if SHADOWS && transmits && counted > lit {
        // Light through the occluders, at their mean thickness and at the entry cosine of the
        // first occluded column (one T per light).
        let occluded = f32(counted - lit);
        let entry = entry_cosine(
            first_occluded.layer,
            first_occluded.texel,
            texel_mm,
            depth_range_mm,
        );
        terms.transmission += through_weight / weights
            * transmission_profile(through_mm / occluded, entry);
    }
    return terms;
}
