#include "server/codec/svg_preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/pipeline.h"
#include "server/codec/json_codec.h"

namespace lipmap::preview {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string escape_xml(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        // Control characters are not allowed in XML 1.0 (except tab, newline, carriage return).
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') out += ' ';
        else out += c;
    }
  }
  return out;
}

// %.6g, never "-0", never "nan"/"inf" (SVG has no such numbers: those become 0).
std::string num(double v) {
  if (!std::isfinite(v)) return "0";
  if (v == 0) return "0";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fixed(double v, int digits) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string bin_label(int i) {
  const auto& e = bin_edges();
  auto txt = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return std::string(buf);
  };
  if (std::isinf(e[i + 1])) return "\xE2\x89\xA5 " + txt(e[i]);  // "≥ 10"
  return txt(e[i]) + " \xE2\x80\x93 " + txt(e[i + 1]);          // "1 – 1.1"
}

}  // namespace

const std::vector<double>& bin_edges() {
  static const std::vector<double> edges = {1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 10.0, kInf};
  return edges;
}

const std::vector<std::string>& bin_colours() {
  // ColorBrewer YlGnBu (8 classes): light = nearly conformal, dark = strongly distorted; no red in it.
  static const std::vector<std::string> colours = {"#ffffd9", "#edf8b1", "#c7e9b4", "#7fcdbb",
                                                   "#41b6c4", "#1d91c0", "#225ea8", "#0c2c84"};
  return colours;
}

int bin_of(double k) {
  if (!(k == k)) return 7;  // NaN
  const auto& e = bin_edges();
  int bin = 0;
  while (bin + 1 < 8 && k >= e[bin + 1]) ++bin;
  return bin;
}

std::string render_svg(const MapPicture& p, const SvgOptions& options) {
  const std::size_t nv = p.uv.size();
  for (std::size_t f = 0; f < p.faces.size(); ++f)
    for (int c : p.faces[f])
      if (c < 0 || static_cast<std::size_t>(c) >= nv)
        throw InternalError("render_svg: face " + std::to_string(f) + " has corner index " + std::to_string(c) +
                            " out of range");
  if (!p.distortion.empty() && p.distortion.size() != p.faces.size())
    throw InternalError("render_svg: " + std::to_string(p.distortion.size()) + " distortion values for " +
                        std::to_string(p.faces.size()) + " faces");

  // uv bounding box (finite points only), extended by the outline.
  double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
  auto extend = [&](const Point2& q) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y)) return;
    x0 = std::min(x0, q.x);
    x1 = std::max(x1, q.x);
    y0 = std::min(y0, q.y);
    y1 = std::max(y1, q.y);
  };
  for (const Point2& q : p.uv) extend(q);
  for (const Point2& q : p.outline) extend(q);
  if (!(x0 <= x1)) x0 = y0 = 0, x1 = y1 = 1;
  double w = x1 - x0, h = y1 - y0;
  const double D = std::max({w, h, 1e-300}) > 1e-300 ? std::max(w, h) : 1.0;
  if (w < 1e-3 * D) { x0 -= 0.0005 * D; x1 += 0.0005 * D; w = x1 - x0; }
  if (h < 1e-3 * D) { y0 -= 0.0005 * D; y1 += 0.0005 * D; h = y1 - y0; }

  const double margin = 0.04 * D;
  const double font = 0.026 * D;
  const double legend_w = 0.46 * D;
  const double line_h = 1.45 * font;
  const double caption_h = (static_cast<double>(p.caption.size()) + 0.6) * line_h;
  const double legend_h = (8 + 6) * line_h + margin;  // title, 8 bins, flipped, inserted, singular, outline
  const double draw_h = std::max(h, legend_h - 2 * margin);
  // Everything in user units: uv point (u, v) is drawn at user (u, -v) (through the group's transform).
  const double vb_x = x0 - margin, vb_y = -y1 - margin;
  std::size_t caption_chars = 0;
  for (const std::string& line : p.caption) caption_chars = std::max(caption_chars, line.size());
  const double vb_w = std::max(w + 2 * margin + legend_w, 0.6 * font * static_cast<double>(caption_chars) + 2 * margin);
  const double vb_h = draw_h + 2 * margin + caption_h;
  const int width_px = std::max(64, options.width_px);
  const int height_px = std::max(32, static_cast<int>(std::lround(width_px * vb_h / vb_w)));

  // Stroke: thin lines between triangles while they are large enough to show them.
  double uv_area = 0;
  for (const Triangle& t : p.faces) {
    const Point2 &a = p.uv[t[0]], &b = p.uv[t[1]], &c = p.uv[t[2]];
    const double ar = 0.5 * std::fabs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    if (std::isfinite(ar)) uv_area += ar;
  }
  const double mean_edge = p.faces.empty() ? D : std::sqrt(2 * uv_area / static_cast<double>(p.faces.size()));
  const double tri_stroke = std::min(0.0015 * D, 0.06 * mean_edge);
  const bool draw_edges = mean_edge > 0.004 * D;

  std::string out;
  out.reserve(200 + p.faces.size() * 64);
  out += "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n";
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + std::to_string(width_px) +
         "\" height=\"" + std::to_string(height_px) + "\" viewBox=\"" + num(vb_x) + " " + num(vb_y) + " " +
         num(vb_w) + " " + num(vb_h) + "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n";
  out += "<title>" + escape_xml(p.title.empty() ? std::string("lipmap map") : p.title) + "</title>\n";
  out += "<desc>uv triangles coloured by conformal distortion K = sigma1/sigma2; red: non-positive triangles; "
         "black line: target boundary polygon; orange dots: inserted vertices; magenta: singular vertices. "
         "y axis points up.</desc>\n";
  out += "<rect x=\"" + num(vb_x) + "\" y=\"" + num(vb_y) + "\" width=\"" + num(vb_w) + "\" height=\"" + num(vb_h) +
         "\" fill=\"#ffffff\"/>\n";

  // ---- triangles, grouped by fill ----
  std::vector<std::vector<int>> groups(9);  // 0..7 bins, 8 flipped
  for (std::size_t f = 0; f < p.faces.size(); ++f) {
    const Triangle& t = p.faces[f];
    const int sign = orientation_sign(p.uv[t[0]], p.uv[t[1]], p.uv[t[2]]);
    if (sign <= 0) groups[8].push_back(static_cast<int>(f));
    else groups[bin_of(p.distortion.empty() ? 1.0 : p.distortion[f])].push_back(static_cast<int>(f));
  }
  const std::string translate = "translate(" + num(x0) + " " + num(-y0) + ") scale(1 -1)";
  out += "<g id=\"triangles\" transform=\"" + translate + "\" stroke-linejoin=\"round\"";
  if (draw_edges) out += " stroke=\"#444444\" stroke-opacity=\"0.45\" stroke-width=\"" + num(tri_stroke) + "\"";
  out += ">\n";
  auto polygon = [&](int f) {
    const Triangle& t = p.faces[f];
    out += "<polygon points=\"";
    for (int c = 0; c < 3; ++c) {
      const Point2& q = p.uv[t[c]];
      if (c) out += ' ';
      out += num(q.x - x0);
      out += ',';
      out += num(q.y - y0);
    }
    out += "\"/>\n";
  };
  for (int g = 0; g < 8; ++g) {
    if (groups[g].empty()) continue;
    out += "<g class=\"bin-" + std::to_string(g) + "\" fill=\"" + bin_colours()[g] + "\"";
    if (!draw_edges) out += " stroke=\"" + bin_colours()[g] + "\" stroke-width=\"" + num(0.5 * mean_edge * 0.05) + "\"";
    out += ">\n";
    for (int f : groups[g]) polygon(f);
    out += "</g>\n";
  }
  if (!groups[8].empty()) {
    // Drawn last so that they are on top, with a red outline that shows even a sliver.
    out += "<g class=\"flipped\" fill=\"" + std::string(kFlippedColour) + "\" stroke=\"" + kFlippedColour +
           "\" stroke-opacity=\"1\" stroke-width=\"" + num(std::max(tri_stroke, 0.002 * D)) + "\">\n";
    for (int f : groups[8]) polygon(f);
    out += "</g>\n";
  }
  out += "</g>\n";

  // ---- target outline ----
  if (!p.outline.empty()) {
    out += "<g id=\"outline\" transform=\"" + translate + "\" fill=\"none\" stroke=\"#000000\" stroke-width=\"" +
           num(0.0025 * D) + "\" stroke-linejoin=\"round\">\n<polygon points=\"";
    for (std::size_t i = 0; i < p.outline.size(); ++i) {
      if (i) out += ' ';
      out += num(p.outline[i].x - x0) + "," + num(p.outline[i].y - y0);
    }
    out += "\"/>\n</g>\n";
  }
  auto dots = [&](const char* id, const std::vector<int>& vertices, const char* fill, double r) {
    if (vertices.empty()) return;
    out += std::string("<g id=\"") + id + "\" transform=\"" + translate + "\" fill=\"" + fill +
           "\" stroke=\"#000000\" stroke-width=\"" + num(0.25 * r) + "\">\n";
    for (int v : vertices) {
      if (v < 0 || static_cast<std::size_t>(v) >= nv) continue;
      out += "<circle cx=\"" + num(p.uv[v].x - x0) + "\" cy=\"" + num(p.uv[v].y - y0) + "\" r=\"" + num(r) + "\"/>\n";
    }
    out += "</g>\n";
  };
  dots("inserted", p.inserted, "#ff7f00", 0.006 * D);
  dots("singular", p.singular, "#e7298a", 0.011 * D);

  // Legend and caption are drawn in local units where the font is 14 high, scaled into the viewBox: text
  // at a font size of a fraction of a user unit renders badly (hinting) in some viewers.
  constexpr double F = 14, LH = 1.45 * F, SW = 1.6 * F;
  const double k = font / F;  // local unit -> user unit
  auto text = [&](double x, double y, const std::string& t) {
    out += "<text x=\"" + num(x) + "\" y=\"" + num(y) + "\">" + escape_xml(t) + "</text>\n";
  };

  // ---- legend (right of the picture) ----
  {
    const double lx = x1 + margin * 1.5, ly = -y1;
    out += "<g id=\"legend\" transform=\"translate(" + num(lx) + " " + num(ly) + ") scale(" + num(k) +
           ")\" font-size=\"14\" fill=\"#000000\">\n";
    text(0, F, "conformal distortion K");
    for (int i = 0; i < 8; ++i) {
      const double y = (i + 1.4) * LH;
      out += "<rect x=\"0\" y=\"" + num(y) + "\" width=\"" + num(SW) + "\" height=\"" + num(F) + "\" fill=\"" +
             bin_colours()[i] + "\" stroke=\"#444444\" stroke-width=\"0.7\"/>\n";
      text(SW * 1.3, y + 0.85 * F, bin_label(i));
    }
    double y = 9.8 * LH;
    out += "<rect x=\"0\" y=\"" + num(y) + "\" width=\"" + num(SW) + "\" height=\"" + num(F) + "\" fill=\"" +
           kFlippedColour + "\"/>\n";
    text(SW * 1.3, y + 0.85 * F, "non-positive (flipped)");
    y += LH;
    out += "<line x1=\"0\" y1=\"" + num(y + 0.5 * F) + "\" x2=\"" + num(SW) + "\" y2=\"" + num(y + 0.5 * F) +
           "\" stroke=\"#000000\" stroke-width=\"2\"/>\n";
    text(SW * 1.3, y + 0.85 * F, "target boundary");
    y += LH;
    out += "<circle cx=\"" + num(0.5 * SW) + "\" cy=\"" + num(y + 0.5 * F) + "\" r=\"" + num(0.3 * F) +
           "\" fill=\"#ff7f00\" stroke=\"#000000\" stroke-width=\"0.8\"/>\n";
    text(SW * 1.3, y + 0.85 * F, "inserted vertex");
    y += LH;
    out += "<circle cx=\"" + num(0.5 * SW) + "\" cy=\"" + num(y + 0.5 * F) + "\" r=\"" + num(0.4 * F) +
           "\" fill=\"#e7298a\" stroke=\"#000000\" stroke-width=\"0.8\"/>\n";
    text(SW * 1.3, y + 0.85 * F, "singular vertex");
    out += "</g>\n";
  }

  // ---- caption (under the picture) ----
  if (!p.caption.empty()) {
    const double cx = x0, cy = -y1 + draw_h + margin + 0.2 * line_h;
    out += "<g id=\"caption\" transform=\"translate(" + num(cx) + " " + num(cy) + ") scale(" + num(k) +
           ")\" font-size=\"14\" fill=\"#000000\">\n";
    for (std::size_t i = 0; i < p.caption.size(); ++i) text(0, (static_cast<double>(i) + 1) * LH, p.caption[i]);
    out += "</g>\n";
  }
  out += "</svg>\n";
  return out;
}

MapPicture picture_of(const ParametrizeResult& result, const std::string& title) {
  MapPicture p;
  const RefinedMap& m = result.map;
  p.uv = m.uv;
  p.faces = m.faces;
  if (result.distortion.per_face.size() == m.faces.size()) p.distortion = result.distortion.per_face;
  else if (m.vertices.size() == m.uv.size()) p.distortion = conformal_distortion(m.vertices, m.faces, m.uv).per_face;
  p.outline = result.polygon.vertices;
  const std::size_t original = m.vertices.size() - std::min(m.vertices.size(), m.inserted.size());
  for (std::size_t i = 0; i < m.inserted.size(); ++i) p.inserted.push_back(static_cast<int>(original + i));
  for (int k : result.classification.singular_vertices)
    if (k >= 0 && static_cast<std::size_t>(k) < result.boundary_loop.size()) p.singular.push_back(result.boundary_loop[k]);
  p.title = title;

  std::string line1 = std::string("verdict: ") + codec::verdict_name(result.classification.verdict);
  if (!result.classification.singular_vertices.empty())
    line1 += ", singular vertices: " + std::to_string(result.classification.singular_vertices.size());
  line1 += ", turning number " + std::to_string(result.classification.turning_number);
  p.caption.push_back(line1);
  p.caption.push_back("vertices " + std::to_string(m.vertices.size()) + ", triangles " + std::to_string(m.faces.size()) +
                      ", inserted " + std::to_string(m.inserted.size()) + ", flipped before refinement " +
                      std::to_string(m.flipped_before_refinement) + ", flipped " + std::to_string(result.flipped));
  std::string line3 = "conformal distortion K: max " + fixed(result.distortion.max, 3) + ", mean " +
                      fixed(result.distortion.mean, 3);
  if (result.optimization.ran)
    line3 += " (optimized, " + std::string(to_string(result.optimization.energy)) + ", " +
             std::to_string(result.optimization.iterations) + " steps; before: max " +
             fixed(result.optimization.before.max, 3) + ", mean " + fixed(result.optimization.before.mean, 3) + ")";
  if (result.untangling.succeeded)
    line3 += "; untangled " + std::to_string(result.untangling.flipped_before) + " flips without refinement";
  p.caption.push_back(line3);
  return p;
}

}  // namespace lipmap::preview
