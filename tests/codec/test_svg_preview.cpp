// The SVG preview of a map (server/codec/svg_preview.h): well-formed XML (parsed here by a small strict parser),
// SVG 1.1 root with a viewBox fitted to the uv bounding box and y up, one polygon per triangle, non-positive
// triangles in red, the outline, inserted and singular vertices marked, the caption escaped.
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/pipeline.h"
#include "server/codec/svg_preview.h"

namespace lipmap {
namespace {

// ---- a minimal strict XML parser (elements, attributes, text, comments, the XML declaration) -------------

struct Element {
  std::string name;
  std::map<std::string, std::string> attrs;
  std::vector<std::unique_ptr<Element>> children;
  std::string text;  // concatenated character data, entities decoded

  const Element* find_id(const std::string& id) const {
    auto it = attrs.find("id");
    if (it != attrs.end() && it->second == id) return this;
    for (const auto& c : children)
      if (const Element* e = c->find_id(id)) return e;
    return nullptr;
  }
  void collect(const std::string& tag, std::vector<const Element*>& out) const {
    for (const auto& c : children) {
      if (c->name == tag) out.push_back(c.get());
      c->collect(tag, out);
    }
  }
  std::vector<const Element*> all(const std::string& tag) const {
    std::vector<const Element*> out;
    collect(tag, out);
    return out;
  }
  std::string attr(const std::string& key) const {
    auto it = attrs.find(key);
    return it == attrs.end() ? std::string() : it->second;
  }
};

class XmlParser {
public:
  explicit XmlParser(const std::string& s) : s_(s) {}

  std::unique_ptr<Element> parse() {
    skip_ws();
    if (starts("<?xml")) {
      const auto end = s_.find("?>", i_);
      if (end == std::string::npos) fail("unterminated XML declaration");
      i_ = end + 2;
    }
    skip_misc();
    if (!starts("<")) fail("no root element");
    auto root = element();
    skip_misc();
    if (i_ != s_.size()) fail("content after the root element");
    return root;
  }

private:
  [[noreturn]] void fail(const std::string& why) {
    throw std::runtime_error("XML error at byte " + std::to_string(i_) + ": " + why);
  }
  bool starts(const char* p) const { return s_.compare(i_, std::char_traits<char>::length(p), p) == 0; }
  void skip_ws() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  void skip_misc() {
    for (;;) {
      skip_ws();
      if (starts("<!--")) {
        const auto end = s_.find("-->", i_);
        if (end == std::string::npos) fail("unterminated comment");
        i_ = end + 3;
      } else {
        return;
      }
    }
  }
  static bool name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':' || c == '.';
  }
  std::string name() {
    const std::size_t b = i_;
    if (i_ >= s_.size() || !(std::isalpha(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_')) fail("bad name");
    while (i_ < s_.size() && name_char(s_[i_])) ++i_;
    return s_.substr(b, i_ - b);
  }
  std::string decode(const std::string& raw) {
    std::string out;
    for (std::size_t k = 0; k < raw.size(); ++k) {
      const char c = raw[k];
      if (c == '<') fail("'<' in character data or attribute value");
      if (c != '&') {
        out += c;
        continue;
      }
      const auto semi = raw.find(';', k);
      if (semi == std::string::npos) fail("unterminated entity");
      const std::string ent = raw.substr(k + 1, semi - k - 1);
      if (ent == "amp") out += '&';
      else if (ent == "lt") out += '<';
      else if (ent == "gt") out += '>';
      else if (ent == "quot") out += '"';
      else if (ent == "apos") out += '\'';
      else if (!ent.empty() && ent[0] == '#') out += '?';
      else fail("unknown entity &" + ent + ";");
      k = semi;
    }
    return out;
  }
  std::unique_ptr<Element> element() {
    ++i_;  // '<'
    auto e = std::make_unique<Element>();
    e->name = name();
    for (;;) {
      const std::size_t before = i_;
      skip_ws();
      if (starts("/>")) {
        i_ += 2;
        return e;
      }
      if (starts(">")) {
        ++i_;
        break;
      }
      if (i_ == before) fail("attributes must be separated by white space");
      const std::string key = name();
      skip_ws();
      if (!starts("=")) fail("attribute without '='");
      ++i_;
      skip_ws();
      if (i_ >= s_.size() || (s_[i_] != '"' && s_[i_] != '\'')) fail("unquoted attribute value");
      const char q = s_[i_++];
      const auto end = s_.find(q, i_);
      if (end == std::string::npos) fail("unterminated attribute value");
      if (e->attrs.count(key)) fail("duplicate attribute " + key);
      e->attrs[key] = decode(s_.substr(i_, end - i_));
      i_ = end + 1;
    }
    for (;;) {
      if (i_ >= s_.size()) fail("unclosed element <" + e->name + ">");
      if (starts("</")) {
        i_ += 2;
        const std::string closing = name();
        if (closing != e->name) fail("</" + closing + "> closes <" + e->name + ">");
        skip_ws();
        if (!starts(">")) fail("bad end tag");
        ++i_;
        return e;
      }
      if (starts("<!--")) {
        skip_misc();
        continue;
      }
      if (starts("<")) {
        e->children.push_back(element());
        continue;
      }
      const auto next = s_.find('<', i_);
      if (next == std::string::npos) fail("text after the last tag");
      e->text += decode(s_.substr(i_, next - i_));
      i_ = next;
    }
  }

  const std::string& s_;
  std::size_t i_ = 0;
};

std::vector<double> numbers(const std::string& s) {
  std::vector<double> out;
  std::string token;
  for (char c : s + " ") {
    if (c == ' ' || c == ',') {
      if (!token.empty()) out.push_back(std::stod(token));
      token.clear();
    } else {
      token += c;
    }
  }
  return out;
}

// A square (side 2) with a centre vertex: 4 triangles. `centre` moves the centre's uv.
preview::MapPicture square_picture(Point2 centre) {
  preview::MapPicture p;
  p.uv = {{0, 0}, {2, 0}, {2, 2}, {0, 2}, centre};
  p.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  p.outline = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  return p;
}

TEST(SvgPreview, WellFormedSvg11WithOnePolygonPerTriangle) {
  preview::MapPicture p = square_picture({1, 1});
  p.distortion = {1.0, 1.3, 2.5, 50.0};
  p.inserted = {4};
  p.singular = {2};
  p.caption = {"verdict: simple", "vertices 5, triangles 4"};
  p.title = "square";
  const std::string svg = preview::render_svg(p);
  std::unique_ptr<Element> root;
  ASSERT_NO_THROW(root = XmlParser(svg).parse()) << svg;
  EXPECT_EQ(root->name, "svg");
  EXPECT_EQ(root->attr("xmlns"), "http://www.w3.org/2000/svg");
  EXPECT_EQ(root->attr("version"), "1.1");
  ASSERT_EQ(root->all("title").size(), 1u);
  EXPECT_EQ(root->all("title")[0]->text, "square");
  // Nothing external: no xlink, no script, no image, no style sheet reference.
  EXPECT_EQ(svg.find("xlink"), std::string::npos);
  EXPECT_EQ(svg.find("<script"), std::string::npos);
  EXPECT_EQ(svg.find("<image"), std::string::npos);
  EXPECT_EQ(svg.find("http://", svg.find("xmlns") + 40), std::string::npos);

  const Element* tris = root->find_id("triangles");
  ASSERT_NE(tris, nullptr);
  EXPECT_NE(tris->attr("transform").find("scale(1 -1)"), std::string::npos);  // y up
  const auto polys = tris->all("polygon");
  ASSERT_EQ(polys.size(), 4u);
  // Each triangle in the group of its bin: K = 1 -> bin-0, 1.3 -> bin-2, 2.5 -> bin-4, 50 -> bin-7.
  for (const char* cls : {"bin-0", "bin-2", "bin-4", "bin-7"}) {
    int found = 0;
    for (const auto& g : tris->children)
      if (g->attr("class") == cls) {
        found += static_cast<int>(g->all("polygon").size());
        EXPECT_NE(g->attr("fill"), preview::kFlippedColour);
      }
    EXPECT_EQ(found, 1) << cls;
  }
  for (const auto& g : tris->children) EXPECT_NE(g->attr("class"), "flipped");
  // Three corners each, finite numbers.
  for (const Element* poly : polys) EXPECT_EQ(numbers(poly->attr("points")).size(), 6u);
  ASSERT_NE(root->find_id("outline"), nullptr);
  EXPECT_EQ(root->find_id("outline")->all("polygon").size(), 1u);
  ASSERT_NE(root->find_id("inserted"), nullptr);
  EXPECT_EQ(root->find_id("inserted")->all("circle").size(), 1u);
  ASSERT_NE(root->find_id("singular"), nullptr);
  EXPECT_EQ(root->find_id("singular")->all("circle").size(), 1u);
  ASSERT_NE(root->find_id("legend"), nullptr);
  EXPECT_GE(root->find_id("legend")->all("rect").size(), 9u);  // 8 bins + flipped
  ASSERT_NE(root->find_id("caption"), nullptr);
  const auto lines = root->find_id("caption")->all("text");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0]->text, "verdict: simple");
}

TEST(SvgPreview, FlippedTriangleIsRed) {
  // Centre moved outside the square past the edge (1,2)-(... ): the triangle (2, 3, 4) turns clockwise.
  preview::MapPicture p = square_picture({1, 3});
  const std::string svg = preview::render_svg(p);
  std::unique_ptr<Element> root;
  ASSERT_NO_THROW(root = XmlParser(svg).parse());
  const Element* tris = root->find_id("triangles");
  ASSERT_NE(tris, nullptr);
  const Element* flipped = nullptr;
  int others = 0;
  for (const auto& g : tris->children) {
    if (g->attr("class") == "flipped") flipped = g.get();
    else others += static_cast<int>(g->all("polygon").size());
  }
  ASSERT_NE(flipped, nullptr);
  EXPECT_EQ(flipped->attr("fill"), preview::kFlippedColour);
  const auto red = flipped->all("polygon");
  ASSERT_EQ(red.size(), 1u);
  EXPECT_EQ(others, 3);
  // It is triangle (2, 3, 4): corners (2,2), (0,2), (1,3) relative to the bounding box corner (0, 0).
  EXPECT_EQ(numbers(red[0]->attr("points")), (std::vector<double>{2, 2, 0, 2, 1, 3}));

  // A degenerate (collinear) triangle is non-positive too.
  preview::MapPicture q = square_picture({1, 2});
  const std::string svg2 = preview::render_svg(q);
  auto root2 = XmlParser(svg2).parse();
  int red2 = 0;
  for (const auto& g : root2->find_id("triangles")->children)
    if (g->attr("class") == "flipped") red2 += static_cast<int>(g->all("polygon").size());
  EXPECT_EQ(red2, 1);
}

TEST(SvgPreview, ViewBoxIsFittedToTheUvBoundingBox) {
  // A far-away, small uv box: [1000, 1000.5] x [-3, -2.9].
  preview::MapPicture p;
  p.uv = {{1000, -3}, {1000.5, -3}, {1000.5, -2.9}, {1000, -2.9}};
  p.faces = {{0, 1, 2}, {0, 2, 3}};
  const std::string svg = preview::render_svg(p);
  auto root = XmlParser(svg).parse();
  const std::vector<double> vb = numbers(root->attr("viewBox"));
  ASSERT_EQ(vb.size(), 4u);
  // User space is (u, -v): the box [1000, 1000.5] x [2.9, 3] must be inside the viewBox...
  EXPECT_LE(vb[0], 1000.0);
  EXPECT_GE(vb[0] + vb[2], 1000.5);
  EXPECT_LE(vb[1], 2.9);
  EXPECT_GE(vb[1] + vb[3], 3.0);
  // ...and the viewBox is on the scale of the box (margins, legend and caption included), not of the origin.
  EXPECT_GT(vb[0], 999.0);
  EXPECT_LT(vb[2], 2.0);
  // The triangles' coordinates are relative to the box corner, translated back by the group transform.
  const Element* tris = root->find_id("triangles");
  EXPECT_NE(tris->attr("transform").find("translate(1000 3)"), std::string::npos) << tris->attr("transform");
  for (const Element* poly : tris->all("polygon"))
    for (double x : numbers(poly->attr("points"))) {
      EXPECT_GE(x, -1e-9);
      EXPECT_LE(x, 0.5 + 1e-9);
    }
  // Width and height in pixels follow the viewBox's aspect ratio.
  const double w = std::stod(root->attr("width")), h = std::stod(root->attr("height"));
  EXPECT_NEAR(w / h, vb[2] / vb[3], 0.01 * vb[2] / vb[3]);
}

TEST(SvgPreview, TextIsEscaped) {
  preview::MapPicture p = square_picture({1, 1});
  p.title = "a <b> & \"c\"";
  p.caption = {"K < 2 & flips > 0", std::string("control\x01" "char")};
  const std::string svg = preview::render_svg(p);
  std::unique_ptr<Element> root;
  ASSERT_NO_THROW(root = XmlParser(svg).parse()) << svg;
  EXPECT_EQ(root->all("title")[0]->text, "a <b> & \"c\"");
  const auto lines = root->find_id("caption")->all("text");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0]->text, "K < 2 & flips > 0");
  EXPECT_EQ(lines[1]->text, "control char");
}

TEST(SvgPreview, LargeMeshHasOnePolygonPerTriangle) {
  preview::MapPicture p;
  const int n = 120;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) p.uv.push_back({i + 0.3 * std::sin(j * 0.1), j + 0.0});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i;
      p.faces.push_back({a, a + 1, a + n + 2});
      p.faces.push_back({a, a + n + 2, a + n + 1});
    }
  for (std::size_t f = 0; f < p.faces.size(); ++f) p.distortion.push_back(1.0 + 0.001 * static_cast<double>(f % 9000));
  const std::string svg = preview::render_svg(p);
  auto root = XmlParser(svg).parse();
  EXPECT_EQ(root->find_id("triangles")->all("polygon").size(), p.faces.size());
  EXPECT_EQ(root->find_id("outline"), nullptr);  // no outline given
}

TEST(SvgPreview, BadInputThrows) {
  preview::MapPicture p = square_picture({1, 1});
  p.distortion = {1.0};
  EXPECT_THROW(preview::render_svg(p), InternalError);
  p.distortion.clear();
  p.faces.push_back({0, 1, 9});
  EXPECT_THROW(preview::render_svg(p), InternalError);
}

TEST(SvgPreview, BinsFollowTheHistogramEdges) {
  EXPECT_EQ(preview::bin_of(1.0), 0);
  EXPECT_EQ(preview::bin_of(1.0999), 0);
  EXPECT_EQ(preview::bin_of(1.1), 1);
  EXPECT_EQ(preview::bin_of(9.99), 6);
  EXPECT_EQ(preview::bin_of(10), 7);
  EXPECT_EQ(preview::bin_of(std::numeric_limits<double>::infinity()), 7);
  EXPECT_EQ(preview::bin_colours().size(), 8u);
  for (const std::string& c : preview::bin_colours()) EXPECT_NE(c, preview::kFlippedColour);
}

TEST(SvgPreview, PictureOfAResultCarriesCountsAndMarks) {
  // A hand-made result (no pipeline run): 5 original vertices + 1 inserted on edge (0, 4).
  ParametrizeResult r;
  r.classification.verdict = Verdict::weakly_self_overlapping;
  r.classification.turning_number = 2;
  r.classification.singular_vertices = {1};
  r.boundary_loop = {0, 1, 2, 3};
  r.polygon.vertices = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  r.map.vertices = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {1, 1, 0}, {0.5, 0.5, 0}};
  r.map.uv = {{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5, 0.5}};
  r.map.faces = {{0, 1, 5}, {1, 4, 5}, {1, 2, 4}, {2, 3, 4}, {3, 5, 4}, {3, 0, 5}};
  r.map.inserted = {{0, 4, 0.5}};
  r.map.flipped_before_refinement = 3;
  r.distortion = conformal_distortion(r.map.vertices, r.map.faces, r.map.uv);
  const preview::MapPicture p = preview::picture_of(r, "t");
  EXPECT_EQ(p.inserted, std::vector<int>{5});
  EXPECT_EQ(p.singular, std::vector<int>{1});
  EXPECT_EQ(p.faces.size(), 6u);
  EXPECT_EQ(p.distortion.size(), 6u);
  std::string caption;
  for (const auto& line : p.caption) caption += line + "\n";
  EXPECT_NE(caption.find("weakly_self_overlapping"), std::string::npos) << caption;
  EXPECT_NE(caption.find("vertices 6"), std::string::npos) << caption;
  EXPECT_NE(caption.find("triangles 6"), std::string::npos) << caption;
  EXPECT_NE(caption.find("inserted 1"), std::string::npos) << caption;
  EXPECT_NE(caption.find("flipped before refinement 3"), std::string::npos) << caption;
  EXPECT_NE(caption.find("max 1.000"), std::string::npos) << caption;
  auto root = XmlParser(preview::render_svg(p)).parse();
  EXPECT_EQ(root->find_id("triangles")->all("polygon").size(), 6u);

  // Written once to a file for a look (LIPMAP_PREVIEW_DIR), never compared with anything.
  if (const char* dir = std::getenv("LIPMAP_PREVIEW_DIR"); dir && *dir)
    std::ofstream(std::string(dir) + "/svg_preview_result.svg") << preview::render_svg(p);
}

}  // namespace
}  // namespace lipmap
