#pragma once
// Reads a generated HTML page the way a browser would (libxml2's HTML parser) and answers
// XPath questions about it, so the tests check the document's structure, not its bytes.
#include <libxml/HTMLparser.h>
#include <libxml/xpath.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace standcal::test {

class HtmlDocument {
 public:
  explicit HtmlDocument(const std::string& html)
      : doc_(htmlReadMemory(html.data(), static_cast<int>(html.size()), "certificate.html", "UTF-8",
                            HTML_PARSE_NOERROR | HTML_PARSE_NOWARNING | HTML_PARSE_NONET)) {
    if (!doc_) throw std::runtime_error("libxml2 could not parse the page");
  }
  ~HtmlDocument() { xmlFreeDoc(doc_); }
  HtmlDocument(const HtmlDocument&) = delete;
  HtmlDocument& operator=(const HtmlDocument&) = delete;

  // The text content of every node the XPath expression selects (attributes: their value).
  std::vector<std::string> texts(const std::string& xpath) const {
    std::unique_ptr<xmlXPathContext, decltype(&xmlXPathFreeContext)> ctx(xmlXPathNewContext(doc_),
                                                                         xmlXPathFreeContext);
    std::unique_ptr<xmlXPathObject, decltype(&xmlXPathFreeObject)> result(
        xmlXPathEvalExpression(reinterpret_cast<const xmlChar*>(xpath.c_str()), ctx.get()),
        xmlXPathFreeObject);
    if (!result) throw std::runtime_error("bad XPath: " + xpath);
    std::vector<std::string> out;
    if (!result->nodesetval) return out;
    for (int i = 0; i < result->nodesetval->nodeNr; ++i) {
      xmlChar* content = xmlNodeGetContent(result->nodesetval->nodeTab[i]);
      out.emplace_back(content ? reinterpret_cast<const char*>(content) : "");
      xmlFree(content);
    }
    return out;
  }

  // The one text the expression selects; throws when it selects none or several.
  std::string text(const std::string& xpath) const {
    const std::vector<std::string> all = texts(xpath);
    if (all.size() != 1)
      throw std::runtime_error(xpath + ": selects " + std::to_string(all.size()) +
                               " nodes, expected 1");
    return all.front();
  }

  std::size_t count(const std::string& xpath) const { return texts(xpath).size(); }

 private:
  xmlDocPtr doc_;
};

}  // namespace standcal::test
