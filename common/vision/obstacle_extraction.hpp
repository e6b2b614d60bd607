#pragma once
// Obstacles one by one (seed paper, Sec. III, figures 3f, 4b and 5).
//
// Each iteration: the correlation of what is left (only the rows that changed
// are recomputed) -> a histogram over offsets of the per-row excess over the
// row's median -> the strongest offset d*. Left features matching the right
// at d* (+-offset_tolerance_px) -> column histogram -> lateral borders; row
// histogram inside that stripe -> top and bottom. The cluster is labelled and
// removed, and the loop repeats until nothing significant is left or
// max_obstacles are found.
//
// Beyond the paper:
//  - the histograms only locate the cluster: its extent is the connected set of
//    cell_px cells matching at d* (of the connected sets reaching into the histograms'
//    box, the one with the most matches among those tall enough to stand);
//  - obstacles stand on the ground: only rows above the ground contact row of
//    d* (the row where the ground offset equals d*) count; a cluster floating
//    far above the last row it could show in is rejected; the box bottom is the
//    contact row;
//  - long walls receding in depth grow over neighbouring offsets whose
//    matched features continue the cluster sideways, so they come out as one
//    obstacle spanning [min_offset_px, max_offset_px] instead of slices;
//  - a cluster at the offset of an earlier one and overlapping it is merged, and so is
//    a floating one resting on it (a person's upper body found after the legs);
//  - below the obstacle thresholds, a weaker cluster is still kept when its box at d*
//    has a person's size in metres (far people show only a few dozen rows);
//  - after the loop, a left-right test trims the band left of each obstacle that only the
//    left camera sees (trimOccludedLeft), and the sides of plain faces, at one offset or
//    receding in depth, are joined into one obstacle (joinPlainFaces), and so are parts of one
//    face receding in depth whose top outline runs between them (joinRecedingParts); a part of a
//    plain face receding in depth grows along its predicted top outline (growAlongTopOutline); a part
//    rejected as floating whose foot something nearer hides becomes an obstacle (keepHiddenFeet); last, side columns
//    whose pixels do not pin the offset (the feature mask's reach into a plain surround) are
//    trimmed (trimPlainSides), and so are side columns none of whose pixels stands at the
//    offset rather than at their row's ground (level streaks of the ground, trimStreakSides).
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "config/params.hpp"
#include "vision/correlation.hpp"
#include "vision/segmentation_types.hpp"

namespace sg {

struct ObstacleParams {
  int max_obstacles = 12;           // obstacles per frame
  bool refine_offset = true;        // an obstacle's offset is the one its own pixels match best within
                                    // the offset tolerance of d* (d* is the peak of whole rows)
  // The removal takes an obstacle's pixels that match at their row's ground offset (+-1): near a
  // standing object's foot that is its own offset, so what is left matches best a pixel or two
  // farther. Once the obstacles are final, one spanning few offsets takes the offset, within
  // +-settle_offset_span_px, at which most of the feature pixels in its box labelled it, the
  // ground or the background match (0: off).
  int settle_offset_span_px = 2;
  int max_iterations = 24;          // candidates examined per frame (rejected ones included)
  int offset_tolerance_px = 1;      // offsets within +-this of d* match
  int grey_tolerance = 12;          // grey levels, as in the correlation
  int match_half_window_px = 1;     // a pixel matches when its horizontal neighbours within this match too:
                                    // chance matches (occluded bands, aliased texture) fall by a power of 3
  int min_row_excess = 5;           // matches above the row median: the row shows something at that offset
                                    // (a 5-pixel dilated edge pair matched on one row)
  int min_peak_matches = 200;       // histogram excess of d*; below: nothing significant is left
                                    // (a 1.7 m person 30 m away on the KITTI rig: ~40 rows x ~5 matches)
  double extent_fraction = 0.2;     // histogram bins above this fraction of the peak belong to the obstacle
  int gap_px = 6;                   // gaps tolerated inside an obstacle's histograms (pixels)
  int smooth_px = 2;                // half width of the box filter on the histograms (pixels)
  int min_height_px = 12;           // smaller clusters are rejected
  int min_width_px = 2;             // narrower clusters are rejected; the occluded-band trim leaves this many columns
  int min_cluster_features = 110;   // matched feature pixels needed for an obstacle (about half of that
                                    // person; 110, not 100: two residue clusters of kitti_rig's road surface stay below it)
  double min_match_fraction = 0.5;  // matched share of the box's remaining features: chance matches of
                                    // unmatched texture (occlusions, aliasing) stay well below it
  int share_half_window_px = 0;     // the share counts each pixel on its own (a thin structure's
                                    // neighbours often show what lies behind it) ...
  int share_offset_slack_px = 0;    // ... at the column's offset +-(offset_tolerance_px + this)
  int contact_tolerance_px = 12;    // allowed gap between the cluster bottom and its ground contact row ...
  double contact_tolerance_fraction = 0.35;  // ... or this fraction of its height, whichever is larger
  double min_support_fraction = 0.5;  // share of the rows below a cluster, down to the last row it could show
                                      // in, that must keep a match at its offset for it to stand (legs)
  double plain_support_min_width_m = 0.5;  // clusters at least this wide (metres; 0: none) leave rows without a
                                           // feature pixel in their columns out of that share (a plain lower body)
  double ground_clearance_px = 2.5;  // rows whose ground offset is within this of d are left out (ground residue)
  double background_margin_px = 1.5;  // offsets within this of the background line are background residue
  double max_range_m = 50.0;        // offsets of farther obstacles are not searched (0: no limit): a 1.7 m
                                    // person is 25 px tall at 49 m on the KITTI rig (the smallest labelled)
  bool grow_walls = true;           // grow clusters over neighbouring offsets (walls receding in depth)
  bool ungrown_retry = true;        // a grown cluster failing the matched share is judged on its own columns
  int min_growth_matches = 20;      // matched pixels an extension needs
  int cell_px = 4;                  // side of the cells whose connected set is the cluster (0: histograms only)
  int cell_reach = 1;               // cells connect within this many cells of each other
  int min_cell_matches = 4;         // matched pixels of an active cell (a few rows of an outline)
  int top_row_matches = 2;          // rows above the cells, within the row histogram's extent, join with
                                    // this many matches in the cluster's columns (a head; 0: off) ...
  int top_gap_rows = 2;             // ... with up to this many rows without between them
  double merge_overlap = 0.5;       // fraction of the smaller box inside an earlier obstacle at a close offset: merge
  // Plain faces (a wall, a box, a vehicle's side without texture) show features only along
  // their outline: the two sides come out as narrow obstacles at one offset. They are one
  // obstacle when the columns between them are plain and the face's top outline joins them.
  bool trim_occluded_left = true;  // left-right consistency on the band left of each obstacle
  double occluded_max_share = 1.0;  // share of an obstacle's width that band may take (min_width_px columns stay)
  // The dilated feature mask reaches past an object's outline; against a plain or smooth
  // surround those pixels match at the object's offset as well as at any other.
  bool trim_plain_sides = true;    // side columns without a pixel that pins the offset are trimmed ...
  int plain_side_reach_px = 3;     // ... up to this many per side: the features' dilation (2) plus the Sobel's 1
  double plain_side_contact_px = 2.0;  // rows whose ground offset is within this of the obstacle's (its foot: the
                                       // ground there matches at its offset too) pin nothing (negative: they do)
  // Two objects side by side at close offsets (1-3 px) come out as one cluster at the nearer's
  // offset tolerance: the other's outline matches within it.
  bool trim_foreign_sides = true;  // side columns whose pinning pixels match best at another offset are trimmed
  int foreign_search_px = 4;       // offsets searched around the obstacle's, each side
  int foreign_min_step_px = 2;     // a pixel matching best this far from the obstacle's offset or farther ...
  double foreign_min_depth_m = 1.0;  // ... and this far in depth is another object's
  double foreign_max_share = 0.7;    // largest share of a box's width trimmed
  double thin_min_aspect = 5.0;     // obstacles this many times taller than wide are thin (0: none) ...
  double thin_side_share = 0.1;    // ... and lose side columns holding less than this share of the fullest's pixels
  bool trim_foot_skirt = true;     // side columns holding the obstacle's pixels at its foot only are trimmed
  double tall_side_min_aspect = 1.5;  // an obstacle this many times taller than wide (0: none) loses every side
                                      // column pinning nothing, not only plain_side_reach_px of them ...
  double tall_side_keep_share = 0.5;  // ... when at least this share of its pixels stays
  bool drop_unpinned = true;       // an obstacle at one offset none of whose pixels pins it (away from its foot) is dropped
  // A level streak of the ground beside an obstacle matches at its offset as well as at its own
  // row's, and pins where its texture changes along the row: the pinning trims leave it.
  bool trim_streak_sides = true;      // side columns with no pixel standing at the offset are trimmed ...
  int streak_min_standing = 4;        // ... standing pixels a column needs to stay
  int streak_max_cost = 40;           // ... 5-pixel window SAD at the offset (+-1) up to which a pixel stands
                                      // (with stride_cost_margin)
  double streak_top_share = 0.15;     // ... a pixel in this top share of the box's rows keeps the column
                                      // (a head and shoulders, a roof line)
  double streak_min_held_share = 0.5; // ... share of the trimmed columns that must hold the obstacle's pixels
  double streak_keep_share = 0.5;     // ... share of its pixels that must stay
  // A person joined to something at the same offset by a link along the ground (the ground's
  // residue at their common foot row, a shadow's edge) is split there; person-sized parts are kept.
  bool split_ground_links = true;
  double link_min_part_width_m = 0.2;  // narrowest part kept as a person's (seen from the side, the chest's depth)
  bool link_keep_parts = true;         // the other person-sized parts become obstacles of their own
  bool link_plain_outline = true;      // only plain link columns count as a face's upper outline ...
  bool link_face_pinning = true;       // ... and in a face joined from parts found apart, a column is plain
                                       // when few of its features pin an offset (the joins' own test: a
                                       // vehicle's window band and panel edges match at every offset)
  bool join_stacked_parts = true;      // a floating part resting on a nearer obstacle joins it ...
  double stacked_max_depth_m = 2.5;    // ... when at most this much farther (a vehicle's cabin behind its tail)
  // A part rejected as floating whose foot something nearer hides (a post behind a plain wall) is
  // an obstacle of its own: at least weak_min_height_m tall, ...
  bool keep_hidden_feet = true;
  double hidden_foot_max_behind = 0.1;          // ... at most this share of the pixels below it, down to
                                                // its contact row, labelled ground or background ...
  double hidden_foot_min_behind_across = 0.3;   // ... and at least this share across the image on those rows
  bool join_plain_faces = true;
  double plain_max_feature_fraction = 0.05;  // share of the gap's inner pixels that are features pinning an
                                             // offset (not along a horizontal edge) up to which it is plain;
                                             // with one side only, of all its features
  bool plain_late_one_sided = true;          // after the receding joins, one-sided faces also over plain gaps
                                             // with level edges (a vehicle's side), where the terrain shows
                                             // and a pixel in the gap pins an offset
  double plain_min_outline_fraction = 0.5;   // share of the gap's columns whose top outline matches at the offset
  double plain_max_width_m = 15.0;           // widest gap joined (a long vehicle's side)
  double plain_height_tolerance = 0.25;      // a receding face's two sides: heights in metres within this
  bool front_of_face = true;                 // a nearer part with a farther face on one side and another
                                             // part of that face beyond it on the other (tops level, the
                                             // face plain between) stands in front of it: it is not the
                                             // face's end, for the plain faces' and the receding joins
  bool plain_one_sided = true;               // a face with one side found reaches as far as its top outline
  bool plain_raise_top = true;               // a face's top outline may lie above its side's top, where the
                                             // gap stops being plain ...
  double plain_raise_min_gap_m = 0.5;        // ... over a gap at least this wide (metres; narrower: a person)
  bool textured_gap_not_plain = true;        // receding parts: a textured gap is never judged as a plain one
  double textured_gap_min_pinning = 0.05;    // receding parts: share of a textured gap's features that must
                                             // pin an offset (fewer: level streaks of the ground, which match
                                             // at every offset, fill it; no face is seen there)
  bool plain_outline_faces = true;           // a plain face receding out of view grows from a part found at
                                             // its far end along its top outline (offset linear along it)
  double plain_outline_min_walk_widths = 0.0;  // columns out to the border, in the part's widths, it needs
                                               // (the outline tested on half as many); 0: any part
  int plain_outline_min_plain_columns = 2;     // of the 8 columns beside the part, how many must be plain
  bool plain_outline_near_end = true;   // a face that stays in view ends where its plain face gives way
                                        // to texture, at a vertical outline matching its offset
  double plain_near_end_edge_share = 0.33;  // ... on at least this share of the face's rows at the end
  // A long face receding in depth (a wall along the road, a vehicle's side) with too little
  // texture for the loop's growth comes out as parts at different offsets along it.
  bool join_receding_parts = true;
  double receding_max_gap_widths = 4.0;      // widest gap between two parts, in widths of the wider part
  int receding_min_offset_step_px = 2;       // parts nearer in offset than this are one offset's (plain faces)
  double receding_min_lateral_m = 1.0;       // the face's plane passes the camera at least this far to the side
                                             // (half a vehicle's width): steeper lines join separate objects
  bool join_across_nearer = true;            // two parts at one offset, with a nearer obstacle between them hiding
                                             // most of the gap (a vehicle behind a pedestrian), are one obstacle
  // A walking person's legs and arms, thin and often matched by the ground or the background
  // at their line's offset too, fall outside the box the histograms give (the torso).
  bool extend_strides = true;        // widen person-tall boxes over side columns whose pixels stand at their offset
  double stride_max_growth = 0.25;   // most columns added per side, as a fraction of the box's height
  int stride_min_pixels = 2;         // standing pixels a column needs
  int stride_gap_px = 2;             // columns without crossed
  int stride_max_cost = 55;          // 5-pixel window SAD at the offset (+-1) up to which a pixel stands at it ...
  int stride_cost_margin = 60;       // ... when lower by this than at its row's line offset (+-1) ...
  int stride_unique_margin = 20;     // ... and by this than at any other offset near the two
  bool stride_unassigned = true;     // unassigned features stand too (a leg's slanted outline matching the
                                     // right image's only within the window, not at the obstacle cells)
  bool stride_stop_at_others = true; // a column holding another obstacle's pixels at another offset ends the widening
  // A plain body (a vehicle's side, a box, a wall) standing on the ground hides the ground and
  // background beyond it: over its rows, its columns hold almost none of their features, while
  // on textured terrain the columns beside it hold many.
  bool grow_over_hidden_ground = true;     // widen obstacles standing on the ground over columns hiding it
  double hidden_max_seen_fraction = 0.125; // a column hides the ground when at most this share of its rows
                                           // holds ground or background features ...
  double hidden_surround_fraction = 0.3;   // ... and shows it at this share or more
  double hidden_min_terrain_fraction = 0.25;  // share of the same rows across the image holding such
                                              // features, below which nothing grows (weak texture)
  int hidden_end_columns = 3;              // columns showing the ground that end the widening
  // A plain wall seen at an angle: the loop finds its far part and the vertical edge of its near
  // end apart (the face between is plain), and the plain-face join widens the far part to that edge.
  bool fold_near_ends = true;          // fold such an edge into the face whose end it stands at
  double near_end_min_aspect = 8.0;    // an edge: at least this many times taller than wide
  bool stretch_to_contact = true;      // a box ending above its ground contact row, within the contact tolerance,
                                       // reaches down to it (the rows near the foot are left out of the loop)
  // A pole's pixels in front of textured hills often match the background's offset too, so the
  // removal takes them and the cluster keeps only the pole's lower part (or a part above).
  bool grow_thin_tops = true;          // grow a narrow obstacle's top up its columns while they match at its offset
  double thin_top_max_width_m = 0.4;   // widest obstacle grown (a post; a person seen from the front is wider)
  int thin_top_gap_rows = 6;           // rows whose pixels do not match crossed
  double thin_top_min_share = 0.5;     // share of the rows added whose pixels match at the offset
  double thin_top_min_contrast = 3.0;  // how many times as often the rows added match at it as the columns beside
  bool thin_top_other_offsets = true;  // or as often as their own columns match at offsets 3 and 6 away
  bool thin_top_plain_beside = true;   // a row with no features beside (plain sky) holds on its own share,
                                       // and the contrast counts only the rows with features beside
  // Person-sized clusters below min_peak_matches / min_cluster_features: a person 25-35 m away
  // shows ~30-45 rows of a narrow outline. Such weaker clusters are kept when their size in
  // metres (from d* and the rig's baseline) is a person's. 0 turns this off.
  int weak_peak_matches = 120;      // histogram excess down to which person-sized clusters are sought
  int weak_cluster_features = 50;   // matched pixels of a person-sized cluster (under half the obstacles' minimum)
  double weak_min_height_m = 0.9;   // a small child
  double weak_max_height_m = 2.1;   // a tall adult
  double weak_max_width_m = 1.2;    // walking, arms swinging, plus the match's spread

  template <class V>
  void visit(V& v) {
    v.field("max_obstacles", max_obstacles, 0, 200, "", "obstacles per frame");
    v.field("refine_offset", refine_offset, 0, 1, "",
            "report the offset (within the tolerance of the histogram's peak) the cluster's own pixels match best");
    v.field("settle_offset_span_px", settle_offset_span_px, 0, 16, "pixels",
            "final offset of an obstacle spanning few offsets: the best match of its box's own, ground and "
            "background features within this many pixels (0: off)");
    v.field("max_iterations", max_iterations, 0, 1000, "", "candidates examined per frame");
    v.field("offset_tolerance_px", offset_tolerance_px, 0, 16, "pixels", "offset tolerance around d*");
    v.field("grey_tolerance", grey_tolerance, 0, 254, "grey levels", "largest left/right grey difference that matches");
    v.field("match_half_window_px", match_half_window_px, 0, 8, "pixels", "half width of the matching window");
    v.field("min_row_excess", min_row_excess, 1, 100000, "pixels", "row excess over its median that counts");
    v.field("min_peak_matches", min_peak_matches, 1, 10000000, "pixels", "weakest offset histogram peak");
    v.field("extent_fraction", extent_fraction, 0.0, 1.0, "", "histogram fraction of the peak inside an obstacle");
    v.field("gap_px", gap_px, 0, 1000, "pixels", "gap tolerated inside an obstacle");
    v.field("smooth_px", smooth_px, 0, 100, "pixels", "histogram smoothing half width");
    v.field("min_height_px", min_height_px, 1, 100000, "pixels", "smallest obstacle height");
    v.field("min_width_px", min_width_px, 1, 100000, "pixels", "smallest obstacle width");
    v.field("min_cluster_features", min_cluster_features, 1, 10000000, "pixels", "smallest cluster");
    v.field("min_match_fraction", min_match_fraction, 0.0, 1.0, "", "matched share of the box's features");
    v.field("share_half_window_px", share_half_window_px, 0, 8, "pixels",
            "matching window of the matched share (0: each pixel on its own)");
    v.field("share_offset_slack_px", share_offset_slack_px, 0, 8, "pixels",
            "offsets beyond the tolerance that count for the matched share");
    v.field("contact_tolerance_px", contact_tolerance_px, 0, 100000, "pixels", "bottom to ground contact gap");
    v.field("contact_tolerance_fraction", contact_tolerance_fraction, 0.0, 10.0, "", "same, fraction of the height");
    v.field("min_support_fraction", min_support_fraction, 0.0, 1.0, "",
            "rows below a cluster, down to the last it could show in, that must keep a match");
    v.field("plain_support_min_width_m", plain_support_min_width_m, 0.0, 1000.0, "metres",
            "clusters this wide leave featureless rows below them out of the support share (0: none)");
    v.field("ground_clearance_px", ground_clearance_px, 0.0, 100.0, "pixels",
            "histograms of offset d skip rows whose ground offset is above d minus this");
    v.field("background_margin_px", background_margin_px, 0.0, 100.0, "pixels", "background residue margin");
    v.field("max_range_m", max_range_m, 0.0, 10000.0, "metres", "farthest obstacle searched (0: no limit)");
    v.field("grow_walls", grow_walls, 0, 1, "", "grow clusters over neighbouring offsets");
    v.field("ungrown_retry", ungrown_retry, 0, 1, "", "judge a grown cluster that fails the matched share on its own columns");
    v.field("min_growth_matches", min_growth_matches, 1, 10000000, "pixels", "matches an extension needs");
    v.field("cell_px", cell_px, 0, 256, "pixels", "cell side of the cluster's connected extent (0: histograms)");
    v.field("cell_reach", cell_reach, 1, 16, "cells", "cells connect within this distance");
    v.field("min_cell_matches", min_cell_matches, 1, 65536, "pixels", "matched pixels of an active cell");
    v.field("top_row_matches", top_row_matches, 0, 65536, "pixels",
            "matches a row above the cells (within the row histogram's extent) needs to join the cluster; 0: off");
    v.field("top_gap_rows", top_gap_rows, 0, 1000, "rows", "rows without matches tolerated above the cells");
    v.field("merge_overlap", merge_overlap, 0.0, 1.0, "", "overlap merging a cluster into an earlier one");
    v.field("trim_occluded_left", trim_occluded_left, 0, 1, "",
            "trim the band left of an obstacle that only the left camera sees");
    v.field("occluded_max_share", occluded_max_share, 0.0, 1.0, "",
            "share of an obstacle's width that band may take (at least min_width_px columns stay)");
    v.field("trim_plain_sides", trim_plain_sides, 0, 1, "",
            "trim side columns whose matched pixels lie in plain surroundings (the feature mask's reach)");
    v.field("plain_side_reach_px", plain_side_reach_px, 0, 64, "pixels",
            "most columns trimmed per side: how far the feature mask reaches past an outline");
    v.field("plain_side_contact_px", plain_side_contact_px, -1.0, 100.0, "pixels",
            "rows whose ground offset is within this of the obstacle's (its foot) do not pin a side column "
            "(negative: they do)");
    v.field("trim_foreign_sides", trim_foreign_sides, 0, 1, "",
            "trim side columns whose pixels pinning an offset match best at another offset");
    v.field("foreign_search_px", foreign_search_px, 1, 64, "pixels", "offsets searched each side of the obstacle's");
    v.field("foreign_min_step_px", foreign_min_step_px, 1, 64, "pixels",
            "distance from the obstacle's offset at which a best match is another object's ...");
    v.field("foreign_min_depth_m", foreign_min_depth_m, 0.0, 100.0, "metres", "... and in depth");
    v.field("foreign_max_share", foreign_max_share, 0.0, 1.0, "", "largest share of a box's width trimmed");
    v.field("thin_min_aspect", thin_min_aspect, 0.0, 100.0, "",
            "an obstacle this many times taller than wide is thin (a pole): its sparse side columns are trimmed; "
            "0: never");
    v.field("thin_side_share", thin_side_share, 0.0, 1.0, "",
            "a thin obstacle's side column holding less than this share of its fullest column's pixels is trimmed");
    v.field("trim_foot_skirt", trim_foot_skirt, 0, 1, "",
            "trim side columns whose pixels of the obstacle all lie at its foot (ground residue beside it)");
    v.field("tall_side_min_aspect", tall_side_min_aspect, 0.0, 100.0, "",
            "an obstacle at one offset this many times taller than wide loses every side column that pins no "
            "offset, not only plain_side_reach_px of them; 0: never");
    v.field("tall_side_keep_share", tall_side_keep_share, 0.0, 1.0, "",
            "... when at least this share of its pixels (and a remnant's least) stays");
    v.field("drop_unpinned", drop_unpinned, 0, 1, "",
            "drop an obstacle at one offset none of whose pixels pins the offset away from its foot "
            "(matches of a plain surround or of level edges, alike at every offset)");
    v.field("trim_streak_sides", trim_streak_sides, 0, 1, "",
            "trim an obstacle's side columns none of whose pixels stands at its offset (level streaks of the ground)");
    v.field("streak_min_standing", streak_min_standing, 1, 10000, "pixels",
            "pixels standing at the offset (streak_max_cost, stride_cost_margin) a side column needs to stay");
    v.field("streak_max_cost", streak_max_cost, 0, 5 * 255, "grey levels",
            "largest window SAD at the offset of a pixel that keeps a side column");
    v.field("streak_top_share", streak_top_share, 0.0, 1.0, "",
            "a side column holding a pixel in this top share of the box's rows stays");
    v.field("streak_min_held_share", streak_min_held_share, 0.0, 1.0, "",
            "share of the trimmed columns that must hold the obstacle's pixels (not a plain face's span)");
    v.field("streak_keep_share", streak_keep_share, 0.0, 1.0, "",
            "share of the obstacle's pixels (and a remnant's least) that must stay");
    v.field("split_ground_links", split_ground_links, 0, 1, "",
            "keep the person-sized part of an obstacle joined to another by pixels at its foot only");
    v.field("link_min_part_width_m", link_min_part_width_m, 0.0, 10.0, "metres",
            "narrowest part kept as a person's");
    v.field("link_keep_parts", link_keep_parts, 0, 1, "",
            "the other parts between links that have a person's size become obstacles of their own");
    v.field("link_plain_outline", link_plain_outline, 0, 1, "",
            "a link column counts as a plain face's (its upper outline matching) only when it is plain");
    v.field("link_face_pinning", link_face_pinning, 0, 1, "",
            "in a face joined from parts found apart, a link column is plain when at most a quarter of its "
            "inner rows are features pinning an offset");
    v.field("join_stacked_parts", join_stacked_parts, 0, 1, "",
            "a candidate rejected as floating that rests on a nearer obstacle joins it (a vehicle's cabin)");
    v.field("stacked_max_depth_m", stacked_max_depth_m, 0.0, 100.0, "metres",
            "largest depth step between a floating part and the obstacle it rests on");
    v.field("keep_hidden_feet", keep_hidden_feet, 0, 1, "",
            "a part rejected as floating whose foot something nearer hides (a post behind a plain wall) is an "
            "obstacle");
    v.field("hidden_foot_max_behind", hidden_foot_max_behind, 0.0, 1.0, "",
            "largest share of the pixels below such a part, down to its contact row, labelled ground or background");
    v.field("hidden_foot_min_behind_across", hidden_foot_min_behind_across, 0.0, 1.0, "",
            "smallest share of ground or background labels across the image on those rows");
    v.field("join_plain_faces", join_plain_faces, 0, 1, "", "join the two sides of a plain face");
    v.field("plain_max_feature_fraction", plain_max_feature_fraction, 0.0, 1.0, "",
            "share of the gap that is features pinning an offset (not horizontal edges; one side only: "
            "any feature) up to which it is plain");
    v.field("plain_late_one_sided", plain_late_one_sided, 0, 1, "",
            "after the receding joins, join one-sided faces over plain gaps holding level edges too (where the terrain "
            "shows and a pixel in the gap pins an offset)");
    v.field("plain_min_outline_fraction", plain_min_outline_fraction, 0.0, 1.0, "",
            "share of the gap's columns whose top outline matches at the sides' offset");
    v.field("plain_raise_top", plain_raise_top, 0, 1, "",
            "look for a face's top outline up the gap, to where it stops being plain, when the side's top has none");
    v.field("plain_raise_min_gap_m", plain_raise_min_gap_m, 0.0, 1000.0, "metres",
            "narrowest gap over which a face's top outline is looked for above its side's top");
    v.field("textured_gap_not_plain", textured_gap_not_plain, 0, 1, "",
            "two parts of a receding face: a textured gap between them is judged by its matches only, not as a "
            "plain gap");
    v.field("textured_gap_min_pinning", textured_gap_min_pinning, 0.0, 1.0, "",
            "two parts of a receding face: share of a textured gap's features that must pin an offset");
    v.field("plain_max_width_m", plain_max_width_m, 0.0, 1000.0, "metres", "widest plain gap joined");
    v.field("plain_outline_faces", plain_outline_faces, 0, 1, "",
            "grow a part along the top outline of a plain face receding out of view");
    v.field("plain_outline_min_walk_widths", plain_outline_min_walk_widths, 0.0, 100.0, "",
            "columns from the part to the image's side that a face out of view needs, in the part's widths");
    v.field("plain_outline_min_plain_columns", plain_outline_min_plain_columns, 0, 8, "columns",
            "of the 8 columns beside a part grown along a face's top outline, how many must be plain");
    v.field("plain_outline_near_end", plain_outline_near_end, 0, 1, "",
            "a face grown along its top outline may end in view, where it stops being plain, at a vertical outline");
    v.field("plain_near_end_edge_share", plain_near_end_edge_share, 0.0, 1.0, "",
            "share of the face's rows at an end in view where the vertical outline matches the end's offset");
    v.field("join_receding_parts", join_receding_parts, 0, 1, "",
            "join parts of a face receding in depth whose top outline runs between them at the offsets of the "
            "line through theirs");
    v.field("receding_max_gap_widths", receding_max_gap_widths, 0.0, 100.0, "",
            "widest gap between two receding parts, in widths of the wider one");
    v.field("receding_min_offset_step_px", receding_min_offset_step_px, 1, 100, "pixels",
            "smallest offset difference between two receding parts");
    v.field("receding_min_lateral_m", receding_min_lateral_m, 0.0, 100.0, "metres",
            "nearest the plane of two receding parts may pass the camera sideways");
    v.field("extend_strides", extend_strides, 0, 1, "",
            "widen person-tall boxes over side columns of ground or background features standing at their offset");
    v.field("stride_max_growth", stride_max_growth, 0.0, 10.0, "", "most columns added per side, fraction of the height");
    v.field("stride_min_pixels", stride_min_pixels, 1, 100000, "pixels", "standing pixels a side column needs");
    v.field("stride_gap_px", stride_gap_px, 0, 1000, "pixels", "columns without standing pixels crossed");
    v.field("stride_max_cost", stride_max_cost, 0, 5 * 255, "grey levels", "largest window SAD at the offset");
    v.field("stride_cost_margin", stride_cost_margin, 0, 5 * 255, "grey levels",
            "how much lower than at the line's offset the SAD at the obstacle's must be");
    v.field("stride_unique_margin", stride_unique_margin, 0, 5 * 255, "grey levels",
            "how much lower than at any other offset near the two the SAD at the obstacle's must be");
    v.field("stride_unassigned", stride_unassigned, 0, 1, "", "unassigned features may stand at the offset too");
    v.field("stride_stop_at_others", stride_stop_at_others, 0, 1, "",
            "stop widening at a column holding pixels of an obstacle outside the offset tolerance");
    v.field("grow_over_hidden_ground", grow_over_hidden_ground, 0, 1, "",
            "widen obstacles standing on the ground over the columns in which they hide the ground beyond");
    v.field("hidden_max_seen_fraction", hidden_max_seen_fraction, 0.0, 1.0, "",
            "largest share of a column's rows with ground or background features for it to hide them");
    v.field("hidden_surround_fraction", hidden_surround_fraction, 0.0, 1.0, "",
            "share of a column's rows with such features from which on it shows the ground");
    v.field("hidden_min_terrain_fraction", hidden_min_terrain_fraction, 0.0, 1.0, "",
            "share of the obstacle's rows across the image with such features needed to grow it");
    v.field("hidden_end_columns", hidden_end_columns, 1, 1000, "columns",
            "columns showing the ground that end the widening");
    v.field("fold_near_ends", fold_near_ends, 0, 1, "",
            "fold a thin nearer edge at a receding face's end, its top at the face's top and its foot on the "
            "ground, into the face");
    v.field("near_end_min_aspect", near_end_min_aspect, 1.0, 1000.0, "",
            "height over width from which an obstacle is an edge");
    v.field("stretch_to_contact", stretch_to_contact, 0, 1, "",
            "stretch a box ending above its ground contact row (within the contact tolerance) down to it");
    v.field("grow_thin_tops", grow_thin_tops, 0, 1, "",
            "grow a narrow obstacle's top up its columns while their pixels match at its offset");
    v.field("thin_top_max_width_m", thin_top_max_width_m, 0.0, 10.0, "metres", "widest obstacle whose top grows");
    v.field("thin_top_gap_rows", thin_top_gap_rows, 0, 1000, "rows", "rows whose pixels do not match crossed");
    v.field("thin_top_min_share", thin_top_min_share, 0.0, 1.0, "",
            "share of the rows added whose pixels must match at the offset");
    v.field("thin_top_min_contrast", thin_top_min_contrast, 0.0, 100.0, "",
            "how many times as often the rows added must match at the offset as the columns beside them");
    v.field("thin_top_other_offsets", thin_top_other_offsets, 0, 1, "",
            "the rows added may instead match at the offset that many times as often as at offsets 3 and 6 "
            "either side of it");
    v.field("thin_top_plain_beside", thin_top_plain_beside, 0, 1, "",
            "a row with no features beside the box (plain sky) holds on its own matched share; the contrast "
            "with the columns beside counts only rows with features there");
    v.field("join_across_nearer", join_across_nearer, 0, 1, "",
            "join two parts at one offset whose gap a nearer obstacle mostly hides");
    v.field("plain_height_tolerance", plain_height_tolerance, 0.0, 10.0, "",
            "relative difference of a receding face's side heights in metres");
    v.field("front_of_face", front_of_face, 0, 1, "",
            "a nearer part with a farther face on one side and another part of it beyond is not the face's end");
    v.field("plain_one_sided", plain_one_sided, 0, 1, "",
            "extend a face with one side found (the other hidden or beyond the image) along its top outline");
    v.field("weak_peak_matches", weak_peak_matches, 0, 10000000, "pixels",
            "weakest offset histogram peak searched for person-sized clusters (0: off)");
    v.field("weak_cluster_features", weak_cluster_features, 1, 10000000, "pixels", "smallest person-sized cluster");
    v.field("weak_min_height_m", weak_min_height_m, 0.1, 10.0, "metres", "shortest person-sized cluster");
    v.field("weak_max_height_m", weak_max_height_m, 0.1, 10.0, "metres", "tallest person-sized cluster");
    v.field("weak_max_width_m", weak_max_width_m, 0.1, 10.0, "metres", "widest person-sized cluster");
  }
  void validate() const { validateParams(*this, "obstacles"); }
};

// Serial reference of simd::windowMatchRow: out[x] for x in [x0, x1) is 1 when left
// pixel x matches the right row at an offset in [d0, d1] over its window of +-half pixels.
void windowMatchRowReference(const std::uint8_t* left, const std::uint8_t* right, int width, int x0, int x1, int d0,
                             int d1, int grey_tolerance, int half, std::uint8_t* out);

class ObstacleExtractor {
 public:
  // fast: rows matched by the vector kernel; false runs the serial reference (identical results).
  explicit ObstacleExtractor(const ObstacleParams& params = {}, bool fast = true);

  // remaining: left features still unexplained (modified: obstacle pixels are cleared).
  // right: right feature image. score/matches: the correlation of `remaining`, valid
  // except on rows with changed_rows[y] != 0 (updated in place). labels: updated with
  // the obstacle labels. obstacles: the result, strongest first. baseline_m: the rig's
  // baseline, which sizes clusters in metres (person-sized weak clusters; <= 0: none).
  void compute(cv::Mat& remaining, const cv::Mat& right, const GroundProfile& ground, Correlator& correlator,
               cv::Mat& score, cv::Mat& matches, std::vector<std::uint8_t>& changed_rows, cv::Mat& labels,
               std::vector<ObstacleCluster>& obstacles, double baseline_m = 0.0, double focal_px = 0.0);

  // Trims the band left of each obstacle that only the left camera sees (ObstacleParams::
  // trim_occluded_left): there the left image shows what is behind, whose texture matches the
  // obstacle's offset by chance; the right pixel of such a match matches the left image at the
  // ground or background offset behind instead. `left` is the whole left feature image.
  // Returns the number of columns trimmed.
  int trimOccludedLeft(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                       std::vector<ObstacleCluster>& obstacles) const;

  // Trims each obstacle's side columns (one offset only, within twice offset_tolerance_px) whose
  // pixels that pin an offset mostly match best, among the obstacle's offset +-foreign_search_px,
  // away from it by foreign_min_step_px and foreign_min_depth_m or more: a neighbouring object at
  // a close offset. From each side inwards, up to the first column voting for the obstacle's
  // offset, and at most foreign_max_share of the box. focal_baseline: f * B of the rig (pixels
  // times metres). Returns the number of columns trimmed.
  int trimForeignSides(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels,
                       std::vector<ObstacleCluster>& obstacles, double focal_baseline) const;

  // Trims each obstacle's side columns that hold no pixel pinning the offset
  // (ObstacleParams::trim_plain_sides): a pixel pins it when its left and right neighbours in
  // the left feature image differ by more than grey_tolerance; elsewhere a match holds at any
  // offset (the plain surround that the dilated feature mask reaches beside an outline).
  // `left` is the whole left feature image. With `ground`, the rows at an obstacle's foot
  // (plain_side_contact_px) pin nothing. Before that, with `ground`, an obstacle at one offset
  // (within twice offset_tolerance_px) loses the side columns holding its pixels at its foot and
  // none above it that pins the offset (trim_foot_skirt: the ground's residue beside the foot),
  // as far as they reach, and a thin obstacle (thin_min_aspect) loses the side columns holding
  // less than thin_side_share of its fullest column's pixels. A tall obstacle at one offset
  // (tall_side_min_aspect) loses its unpinned side columns however many, when at least
  // tall_side_keep_share of its pixels stay. An obstacle at one offset none of
  // whose columns pins the offset is emptied (drop_unpinned: feature_count 0, box width 0;
  // dropRemnants removes it). Returns the number of columns trimmed.
  int trimPlainSides(const cv::Mat& left, cv::Mat& labels, std::vector<ObstacleCluster>& obstacles,
                     const GroundProfile* ground = nullptr) const;

  // Trims an obstacle's side columns that hold a level streak of the ground
  // (ObstacleParams::trim_streak_sides): for an obstacle at one offset, from each side inwards
  // up to the first column that holds a pixel of it in the box's top streak_top_share of rows or
  // streak_min_standing pixels standing at its offset (their 5-pixel window matches the right
  // image there, SAD <= streak_max_cost, lower by stride_cost_margin than at their row's line
  // offset; rows at the foot, plain_side_contact_px, cannot tell). A streak matches at its own
  // row's offset as well as at any other; a person's or an object's outline matches at its own.
  // A side losing plain_side_reach_px columns or fewer keeps them (the outline's dilation, the
  // plain-side trim's), and the trim is made only when at least streak_min_held_share of the
  // columns going hold the obstacle's pixels (a streak, not a plain face's span between its
  // outlines) and streak_keep_share of its pixels (and a remnant's least) stay. Returns the
  // number of columns trimmed.
  int trimStreakSides(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                      std::vector<ObstacleCluster>& obstacles) const;

  // Splits obstacles at one offset joined along the ground (ObstacleParams::split_ground_links):
  // a run of more than plain_side_reach_px columns holding none of the obstacle's pixels above
  // its foot (plain_side_contact_px) parts it. When a part lies between such runs or the box's
  // sides, has the most pixels above the foot, a person's height and a width from
  // link_min_part_width_m to weak_max_width_m (from its offset and baseline_m), and the runs are
  // not a plain face's inside (fewer than plain_min_outline_fraction of their columns matching at
  // the offset along the box's top: a vehicle's or a box's upper outline; with link_plain_outline
  // only plain link columns count, and with link_face_pinning a column of a face joined from parts
  // found apart is plain when at most a quarter of its inner rows are features pinning an offset),
  // the obstacle keeps that part. With link_keep_parts the other
  // parts of a person's size become obstacles of their own (appended); the rest of its pixels
  // become unassigned. Returns the number of columns removed.
  int splitGroundLinks(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                       std::vector<ObstacleCluster>& obstacles, double baseline_m);

  // Joins the two sides of plain faces (ObstacleParams::join_plain_faces): `left` is the whole
  // left feature image (before any removal), `labels` as left by compute(); joined obstacles
  // are relabelled and the later ones renumbered. Only on frames whose ground line was
  // measured (ground.source kHough). With `late` (a second call, after the receding joins and
  // the near ends' folds; plain_late_one_sided), only one-sided faces beside obstacles that are
  // not edges (isEdge) are joined, over a gap of plain columns whatever its level edges (a
  // vehicle's side seen at an angle; its pinning features still at most
  // plain_max_feature_fraction), when the face's inner rows hold hidden_min_terrain_fraction of
  // ground and background features across the image and the gap holds a pixel pinning an
  // offset. Returns the number of joins.
  int joinPlainFaces(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                     std::vector<ObstacleCluster>& obstacles, double baseline_m, bool late = false);

  // Joins parts of one face receding in depth (ObstacleParams::join_receding_parts): two
  // obstacles side by side at different offsets, of one height in metres, are one face when the
  // straight line through their offsets (the offset of a vertical plane is linear along the image
  // row) is a plane passing the camera at least receding_min_lateral_m to the side, and the top
  // outline between them matches those offsets. Only on frames whose ground line was measured.
  // Returns the number of joins.
  int joinRecedingParts(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                        std::vector<ObstacleCluster>& obstacles, double baseline_m);

  // Grows a part of a plain face receding in depth along the face's predicted top outline
  // (ObstacleParams::plain_outline_faces): to the image border when the face runs out of view,
  // else (plain_outline_near_end) to a near end in view. Runs after the joins above, so a part
  // they completed grows from its whole extent; obstacles lying on the grown face at its offset
  // fold into it. Only on frames whose ground line was measured. Returns the parts grown.
  int growAlongTopOutline(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                          std::vector<ObstacleCluster>& obstacles, double baseline_m);

  // A part rejected as floating that rests on a nearer obstacle (a vehicle's cabin, set back
  // above its body) joins it (ObstacleParams::join_stacked_parts). Returns the joins made.
  int joinStackedParts(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels,
                       std::vector<ObstacleCluster>& obstacles, double focal_baseline) const;
  // A part rejected as floating, at least weak_min_height_m tall, below which down to its contact
  // row hardly any pixel shows the ground or background while across the image on those rows many
  // do (ObstacleParams::keep_hidden_feet): its foot is hidden behind something nearer (a post
  // behind a plain wall), and it becomes an obstacle with its visible box. Only on frames whose
  // ground line was measured. Returns the obstacles added.
  int keepHiddenFeet(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, cv::Mat& labels,
                     std::vector<ObstacleCluster>& obstacles, double baseline_m) const;

  // Drops the obstacles that the trims above left with fewer matched pixels than the loop
  // accepts for any cluster (the smaller of min_cluster_features and weak_cluster_features):
  // their pixels return to unassigned and the later obstacles are renumbered.
  // Returns the number dropped.
  int dropRemnants(cv::Mat& labels, std::vector<ObstacleCluster>& obstacles);

  // Widens the box (not the pixels) of each obstacle a person's height (weak_min_height_m ..
  // weak_max_height_m, from its offset and baseline_m) over the side columns holding at least
  // stride_min_pixels ground- or background-labelled features (and unassigned ones with
  // stride_unassigned) that stand at its offset: their 5-pixel window matches the right image at
  // it (+-1, SAD <= stride_max_cost), better by stride_cost_margin than at the line's offset of
  // their row and by stride_unique_margin than at any other offset from 8 below the smaller of the
  // two to 8 above the larger. Rows at the foot (plain_side_contact_px) cannot tell and are left
  // out; a growth of plain_side_reach_px columns or fewer is the outline's own and is not made.
  // With stride_stop_at_others the widening ends before a column holding pixels of another
  // obstacle whose offset lies outside offset_tolerance_px of this one's (another object; a
  // piece of the same person at its offset does not stop it). Returns the number of columns added.
  int extendStrides(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, const cv::Mat& labels,
                    std::vector<ObstacleCluster>& obstacles, double baseline_m) const;

  // Widens the box (not the pixels) of each obstacle at one offset, at least min_width_px wide,
  // whose bottom lies within contact_tolerance_px of its ground contact row (on a measured ground
  // line), over the side columns in which it hides the ground and background beyond it. Over its
  // rows, from its top to 3 rows above the higher of its bottom and contact rows (the foot, where
  // the ground's offset meets its own, cannot tell), a column hides them when at most
  // hidden_max_seen_fraction of those rows hold ground- or background-labelled features, and
  // shows them at hidden_surround_fraction or more. A side grows to its last hiding column before
  // hidden_end_columns showing ones (columns between the two fractions neither grow nor end it);
  // a side that first meets the image border, a column holding another obstacle's pixels outside
  // offset_tolerance_px of its offset, or plain_max_width_m at its offset is not grown: nothing
  // shows where the body ends. Nothing grows unless the same rows across the whole image hold
  // such features on hidden_min_terrain_fraction of their pixels: on weakly textured terrain a
  // column without ground features tells nothing. Returns the number of columns added.
  int growOverHiddenGround(const GroundProfile& ground, const cv::Mat& labels,
                           std::vector<ObstacleCluster>& obstacles, double baseline_m);

  // Grows the top of each obstacle at one offset no wider than thin_top_max_width_m (a post)
  // up its columns, row by row. A row holds when at least two of its features in the box's
  // columns and a min_match_fraction share of them match the right image at the obstacle's
  // offset (+-offset_tolerance_px), a larger share than in the columns beside (as many as the box
  // is wide each side, past plain_side_reach_px: a level streak matches everywhere alike; with
  // thin_top_plain_beside a row with no features beside holds on its own share). Up to
  // thin_top_gap_rows rows that do not hold are crossed; a row holding pixels of another obstacle
  // at another offset ends the growth. The top moves to the highest row that holds when at least
  // thin_top_min_share of the rows added hold and, over all of them, the box's columns match at
  // the offset thin_top_min_contrast times as often as the columns beside (over the rows with
  // features beside, with thin_top_plain_beside; none: this test fails), or (with
  // thin_top_other_offsets) as often as they match, on average, at the offsets 3 and 6 below and
  // above it (+-offset_tolerance_px; those below 0 left out): hills beside a far person can be
  // streaky and match anywhere, while his own texture matches at his offset only. Returns the
  // number of rows added.
  int growThinTops(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                   std::vector<ObstacleCluster>& obstacles, double baseline_m) const;

  // Folds the near end of a receding face into it (ObstacleParams::fold_near_ends): an obstacle
  // nearer than every offset of a face whose offsets span receding_min_offset_step_px or more,
  // taller than wide by near_end_min_aspect, at one of the face's ends (its box within its own
  // width, or 2 columns, of the face's side), its top within an eighth of the face's height (2
  // rows at least) of the face's top, and its bottom within the contact tolerance of its ground
  // contact row. A plain wall seen at an angle shows its near end as such an edge: the wall's
  // height in pixels grows toward it, and the face found at the far part's offsets ends rows above
  // the near end's foot. Nothing without a measured ground line. Returns the number of folds.
  int foldNearEnds(const GroundProfile& ground, cv::Mat& labels, std::vector<ObstacleCluster>& obstacles);
  // Is the obstacle an edge, near_end_min_aspect times taller than wide or more?
  bool isEdge(const ObstacleCluster& o) const;

  // Stretches each obstacle's box down to its ground contact row (ObstacleParams::
  // stretch_to_contact): the lowest row, over the box's columns, where the ground's offset reaches
  // the obstacle's, when the box's bottom lies above it by at most the loop's contact tolerance
  // (contact_tolerance_px, or contact_tolerance_fraction of its height). The loop leaves the rows
  // whose ground offset is within ground_clearance_px of an obstacle's out of its histograms
  // (ground residue), so a box found there ends a few rows above its foot. Nothing without a
  // ground line. Returns the number of rows added.
  int stretchToContact(const GroundProfile& ground, std::vector<ObstacleCluster>& obstacles) const;

  // Settles the offset of each obstacle whose offset range spans at most settle_offset_span_px
  // (ObstacleParams::settle_offset_span_px): of the offsets within that span of its own, the one
  // at which most feature pixels inside its box labelled it, the ground or the background match the
  // right image (each pixel on its own, grey_tolerance; ties: the one nearest its offset, then the
  // smaller); its range takes the offset in. left: the feature image before the removal. Returns
  // the number of obstacles whose offset changed.
  int settleOffsets(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                    std::vector<ObstacleCluster>& obstacles) const;

  const ObstacleParams& params() const { return params_; }

  // Each label's obstacle offset (-1: no obstacle has the label).
  static std::array<int, 256> offsetsOfLabels(const std::vector<ObstacleCluster>& obstacles);

  // An obstacle at one offset: its range within the offset tolerance either side (a face
  // receding in depth spans more).
  bool atOneOffset(const ObstacleCluster& o) const {
    return o.max_offset_px - o.min_offset_px <= 2 * params_.offset_tolerance_px;
  }

  // The fewest matched pixels of any cluster the loop accepts (dropRemnants removes obstacles
  // below it).
  int leastClusterFeatures() const { return std::min(params_.min_cluster_features, params_.weak_cluster_features); }

 private:
  struct Extent {
    int lo = 0;
    int hi = -1;
  };
  void prepareContactRows(const GroundProfile& ground, int rows, int offsets);
  void offsetHistogram(const cv::Mat& matches, const GroundProfile& ground);
  // Extent around the strongest bin of `hist` within [peak_lo, peak_hi], limited to [lo, hi].
  Extent extent(const std::vector<float>& hist, int lo, int hi, int peak_lo, int peak_hi);
  // extent() over a histogram read through `hist(i)`, which is asked only for the bins the
  // smoothing, the peak search and the walk outwards from it look at.
  template <class Hist>
  Extent extentOf(const Hist& hist, int lo, int hi, int peak_lo, int peak_hi) const;
  int rowLimit(int offset) const;  // last row counted in the offset histogram (most permissive column)
  int firstRowReaching(float offset) const;  // first row whose ground offset reaches `offset`, rows when none
  float groundRelative(int offset, int x) const;  // `offset` in column x as a ground offset at the reference column
  int rowLimitAt(int offset, int x) const;  // last row an obstacle at this offset may occupy in column x
  void rowLimitsAt(int offset, int* out) const;  // rowLimitAt of every column (cols_ values)
  int contactRowAt(int offset, int x) const;  // ground contact row of this offset in column x, rows when none
  // The lowest contactRowAt of the offset over the box's columns (at most the last row; -1 when
  // the box holds no column of the image).
  int lowestContact(const cv::Rect& box, int offset) const;
  // Rows a cluster `height` rows tall may end above its contact row and still stand on the ground:
  // contact_tolerance_px, or contact_tolerance_fraction of its height, whichever is larger.
  double contactTolerance(int height) const;

  // Matches of rows at one offset range, evaluated on first use: per row the columns
  // [lo, hi) are valid.
  struct RowMasks {
    int d0 = 0, d1 = -1;
    std::vector<std::uint8_t> bits;  // rows x cols, 0/1
    std::vector<int> lo, hi;         // per row
  };
  void resetMasks(RowMasks& masks, int d0, int d1);
  // The offset within the tolerance of `best` that the box's remaining features match best.
  int ownOffset(const cv::Mat& remaining, const cv::Mat& right, const cv::Rect& box, int best);
  // Row y of `masks`, valid at least over columns [x0, x1) (the whole row by default).
  const std::uint8_t* maskRow(RowMasks& masks, const cv::Mat& remaining, const cv::Mat& right, int y, int x0 = 0,
                              int x1 = -1) {
    if (x1 < 0) x1 = cols_;
    const auto row = static_cast<std::size_t>(y);
    if (masks.lo[row] <= x0 && x1 <= masks.hi[row]) return masks.bits.data() + row * static_cast<std::size_t>(cols_);
    return fillMaskRow(masks, remaining, right, y, x0, x1);
  }
  // maskRow's work when [x0, x1) is not valid yet.
  const std::uint8_t* fillMaskRow(RowMasks& masks, const cv::Mat& remaining, const cv::Mat& right, int y, int x0,
                                  int x1);
  void matchRow(const std::uint8_t* l, const std::uint8_t* r, int x0, int x1, int d0, int d1, std::uint8_t* out);
  // matchRow on rows y0 .. y1 - 1 of `remaining` and `right`, row y into out + y * cols_.
  void matchRows(const cv::Mat& remaining, const cv::Mat& right, int y0, int y1, int x0, int x1, int d0, int d1,
                 int half, std::uint8_t* out);
  // The span a row's first request [a, b) computes: at least kMaskChunk columns around it.
  static constexpr int kMaskChunk = 64;
  void firstMaskSpan(int& a, int& b) const;
  // Rows y0 .. y1 of `masks` whose span is empty get what a first request [x0, x1) of each
  // would (fillMaskRow's chunk), in one kernel call per run of such rows.
  void fillMaskRows(RowMasks& masks, const cv::Mat& remaining, const cv::Mat& right, int y0, int y1, int x0, int x1);
  void matchRow(const std::uint8_t* l, const std::uint8_t* r, int x0, int x1, int d0, int d1, int half,
                std::uint8_t* out);

  ObstacleParams params_;
  bool fast_ = true;
  int rows_ = 0;
  int cols_ = 0;
  int ground_top_ = 0;             // first ground row (the horizon)
  float per_column_ = 0.0f;        // transversal slope of the ground (offset per column)
  float reference_column_ = 0.0f;
  std::vector<float> ground_reach_;  // per row: largest ground offset from the horizon down to it
  std::vector<int> row_limit_;       // per offset: last row counted in its offset histogram
  std::vector<int> col_limit_;       // per column: last row of the current candidate's offset
  std::vector<float> offset_hist_;
  std::vector<int> hist_sum_;         // per offset: excess summed (at most rows x cols)
  std::vector<int> row_excess_;      // fast path: rows x offsets, each row's excess in hist_sum_
  std::vector<int> hist_limit_;      // per offset: last row its histogram counts, -1 when it is left out
  double nearest_offset_ = 0.0;      // offsets below this are beyond max_range_m
  std::vector<int> row_median_;
  std::vector<std::uint8_t> median_stale_;  // rows whose match counts changed since their median
  std::vector<std::uint8_t> mask_stale_;    // rows a sweep changed since the candidate masks were reset
  bool candidate_masks_kept_ = false;       // the candidate masks describe this frame
  std::vector<int> row_values_;
  std::vector<float> col_hist_;
  std::vector<float> row_hist_;
  std::vector<int> col_offset_;      // per column: the offset the cluster matched it at
  struct OffsetRun {
    int x0 = 0, x1 = 0, d = 0;  // columns [x0, x1) share col_offset_ d
  };
  std::vector<OffsetRun> offset_runs_;  // a box sweep's runs of columns (kept: no allocation per frame)
  RowMasks candidate_masks_;         // matches at the current candidate's offset
  RowMasks growth_masks_;            // matches at the offset a wall is grown over
  std::vector<std::uint8_t> match_scratch_;
  std::vector<std::uint8_t> sweep_row_;
  std::vector<std::uint8_t> sweep_rows_;  // fast path: a box's per-column matches, rows x cols
  std::vector<std::uint16_t> col_count_;  // per column: matches (at most the row count, < 2^16)
  std::vector<std::uint8_t> col_count_bytes_;  // ... of up to 255 rows at a time (fast path)
  cv::Mat right_padded_;                  // right features with the correlation kernel's zeros in front
  std::vector<std::uint8_t> cleared_;     // a row's cleared left pixels (their grey values), else 0
  std::vector<int> removed_counts_;       // their matches per offset
  std::vector<std::uint8_t> banned_;  // offsets that gave nothing this frame
  struct FloatingPart {
    cv::Rect box;
    int offset = 0, min_offset = 0, max_offset = 0;
  };
  std::vector<FloatingPart> floating_;  // candidates rejected as floating above their contact this frame
  // Gives `label` to the pixels of f's box that the rejection left unassigned and that match at
  // f's offsets (+-offset_tolerance_px); returns how many.
  int claimUnassigned(const cv::Mat& left, const cv::Mat& right, cv::Mat& labels, const FloatingPart& f,
                      int label) const;
  static constexpr std::uint8_t kCellUnknown = 0, kCellInactive = 1, kCellActive = 2;
  struct Cell {
    std::uint8_t state = kCellUnknown;
    int component = 0;  // connected set it belongs to (0: none yet)
    int matched = 0;
    int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // bounding box of the matched pixels
  };
  std::vector<Cell> cell_;
  std::array<int, 8> block_count_{}, block_present_{};  // growth: a block of columns' evidence
  std::vector<std::uint8_t> band_present_, band_matched_;  // cells: per column of a band of cell rows
  std::vector<int> touched_cells_;  // cells evaluated this iteration (reset before the next)
  std::vector<int> flood_;   // cells still to visit while growing a cluster
  std::vector<ObstacleCluster> kept_;  // joins: the obstacles left after a join
  std::vector<std::uint8_t> folded_;   // joins: per obstacle, whether it goes into the joined one
  // joinPlainFaces: a column of a face receding in depth between two parts.
  struct FaceColumn {
    int x = 0, top = 0, bottom = 0, d0 = 0, d1 = 0;  // column, outlines, offsets matched
    int margin = 0;                                   // rows next to the outlines left out of its inner rows
    int features = 0;                                 // features between the outlines
    bool in_gap = false;                              // between the parts
  };
  std::vector<FaceColumn> face_columns_;
  std::vector<int> seen_in_row_;  // growOverHiddenGround, late plain-face joins: ground and background features per row
  std::vector<std::uint8_t> hidden_columns_;  // joinPlainFaces: gap columns behind a nearer obstacle
  std::vector<std::uint8_t> outline_hits_;    // growAlongTopOutline: per tested column, the outline matched
  std::vector<std::uint8_t> face_hits_;       // faceTop: per gap column, the outline matched at the row taken
  std::vector<std::uint8_t> raised_hits_;     // faceTop: the same at a raised row, before it is taken
  std::vector<int> pixels_above_foot_;        // splitGroundLinks: an obstacle's pixels above its foot per column
  struct LinkPart {
    int a = 0, b = 0;  // columns relative to the box
  };
  std::vector<LinkPart> link_parts_;          // splitGroundLinks: the parts between links of one obstacle
  std::vector<ObstacleCluster> split_off_;    // splitGroundLinks: parts that become obstacles of their own
  // Does column x of the left feature image match the right at an offset in [d0, d1] on a row
  // within 2 of `top`: a face's upper outline there (joinPlainFaces, splitGroundLinks)?
  bool outlineAt(const cv::Mat& left, const cv::Mat& right, int top, int x, int d0, int d1) const;
  // The row of a plain face's top outline over the gap from column `first` to `end` (exclusive,
  // step `dir`) beside obstacle o: o's top when at least plain_min_outline_fraction of the gap's
  // columns hold an outline there; else, with plain_raise_top, the first row above it at which the
  // gap stops being plain, when that row is outlined so and o's columns next to the gap hold
  // matching features on a quarter of the rows up to it; else o's top. face_hits_ holds, per gap
  // column from `first`, whether the outline matched at the row returned.
  struct FaceTop {
    int row;       // the outline's row
    int outlined;  // gap columns holding a matching outline within 2 rows of it
  };
  FaceTop faceTop(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels, const ObstacleCluster& o,
                  int first, int end, int dir, int d0, int d1, double baseline_m);
  // Does the ground, background or (stride_unassigned) unassigned feature at (y, x) stand at
  // offset d (extendStrides' test)?
  bool standsAt(const cv::Mat& left, const cv::Mat& right, const GroundProfile& ground, const cv::Mat& labels, int y,
                int x, int d) const;
  // The matches of the features of `box` with the right image at the offsets 3 and 6 below and
  // above d (+-offset_tolerance_px), summed over the `windows` of them not reaching below 0. A
  // texture matches at its own offset only; a level streak or a plain surround matches at any.
  struct OtherOffsetMatches {
    long matches = 0;
    int windows = 0;
  };
  OtherOffsetMatches matchesAtOtherOffsets(const cv::Mat& left, const cv::Mat& right, const cv::Mat& labels,
                                           const cv::Rect& box, int d) const;
  // Is (y, x) at obstacle o's foot: the ground's offset there within plain_side_contact_px of o's?
  bool atFoot(const GroundProfile& ground, const ObstacleCluster& o, int y, int x) const;
  // Obstacle i takes in `reach` and the obstacles mostly inside it whose offsets meet
  // [d_lo, d_hi]; the others are renumbered with their labels, and i follows obstacle i.
  void foldInto(std::size_t& i, const cv::Rect& reach, int d_lo, int d_hi, cv::Mat& labels,
                std::vector<ObstacleCluster>& obstacles);
  // Obstacle i becomes `joined`, and the obstacles marked in folded_ go into it (their pixels take
  // its label); the others keep their order and are renumbered with their labels, and i follows
  // obstacle i.
  void replaceFolded(std::size_t& i, const ObstacleCluster& joined, cv::Mat& labels,
                     std::vector<ObstacleCluster>& obstacles);
  // Obstacle o keeps columns [x0, x1] of its box; its pixels outside become unassigned.
  static void narrowTo(ObstacleCluster& o, int x0, int x1, cv::Mat& labels);
};

}  // namespace sg
